"""Validated run settings shared by the training commands (``cmdp-train stage1|stage2``).

A run's settings are a pydantic model: the TOML config file's table, then ``--set key=value``
overrides on top, checked before anything runs; every bad setting is reported at once with its
fix, naming the file (or ``--set``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, model_validator

# Scalars are strict, as in the case: a quoted "3" or a 2.5 for a count is a mistake to report.
Count = Annotated[int, Strict(), Field(gt=0)]
CountOrZero = Annotated[int, Strict(), Field(ge=0)]
Rate = Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]
RateOrZero = Annotated[float, Strict(), Field(ge=0, allow_inf_nan=False)]
Share = Annotated[float, Strict(), Field(ge=0, le=1, allow_inf_nan=False)]
Sizes = Annotated[list[Count], Field(min_length=1)]



class RunConfig(BaseModel):
    """Base of the stage configs: unknown keys are errors; ``load`` reads file + overrides."""

    model_config = ConfigDict(extra="forbid")

    @model_validator(mode="after")
    def _cpus_within_copies(self) -> RunConfig:
        n_envs, num_cpus = getattr(self, "n_envs", None), getattr(self, "num_cpus", None)
        if n_envs is not None and num_cpus is not None and num_cpus > n_envs:
            raise ValueError(f"num_cpus = {num_cpus} exceeds n_envs = {n_envs}; "
                             "fix: lower num_cpus")
        return self

    @classmethod
    def load(cls, path: Path | None, overrides: list[str] = ()) -> RunConfig:
        """The config file's settings with ``--set key=value`` overrides on top, validated;
        a ``ValueError`` names the file (or ``--set``) and every bad setting with its fix."""
        import tomllib

        data = {}
        if path is not None:
            try:
                data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
            except (OSError, tomllib.TOMLDecodeError) as err:
                raise ValueError(f"{path}: cannot read the config ({err}); fix: check the "
                                 "path and the TOML syntax") from None
        set_keys = set()
        for item in overrides:
            key, sep, value = item.partition("=")
            set_keys.add(key)
            if not sep:
                raise ValueError(f"--set {item!r}: write key=value, e.g. --set seed=3")
            try:
                data[key] = tomllib.loads(f"v = {value}")["v"]
            except tomllib.TOMLDecodeError:
                data[key] = value  # a bare string

        def where(keys) -> str:  # a setting given by --set is blamed on --set, not the file
            return "--set" if path is None or set(keys) <= set_keys else str(path)

        unknown = sorted(set(data) - set(cls.model_fields))
        if unknown:
            import difflib

            hints = [f"{k} (did you mean {close[0]}?)" if (close := difflib.get_close_matches(
                k, list(cls.model_fields), n=1)) else k for k in unknown]
            raise ValueError(f"{where(unknown)}: unknown setting(s) {', '.join(hints)}; "
                             f"known: {', '.join(cls.model_fields)}")
        try:
            return cls.model_validate(data)
        except ValidationError as err:
            keys = {str(e["loc"][0]) for e in err.errors() if e["loc"]}
            raise ValueError(f"{where(keys) if keys else path or '--set'}: "
                             + "; ".join(_config_problems(err))) from None



def _config_problems(error: ValidationError) -> list[str]:
    """pydantic's errors as ``name = value must be ...; fix: ...``, one per bad setting."""
    out = []
    for err in error.errors():
        loc = [str(k) for k in err["loc"]]
        value = err.get("input")
        kind, ctx = err["type"], err.get("ctx", {})
        if not loc:  # a model validator's own message
            out.append(err["msg"].removeprefix("Value error, "))
            continue
        name = loc[0] if len(loc) == 1 else f"{loc[0]}[{loc[1]}]"
        if kind in ("int_type", "int_from_float", "int_parsing"):
            text = "must be a whole number (without quotes or a decimal point)"
        elif kind in ("float_type", "float_parsing"):
            text = "must be a number (without quotes)"
        elif kind in ("list_type", "too_short"):
            text = "must be a non-empty list of positive whole numbers, e.g. [128, 128]"
        elif kind == "greater_than" and ctx.get("gt") == 0:
            text = "must be positive"
        elif kind == "greater_than_equal" and ctx.get("ge") == 0:
            text = "must be zero or positive"
        elif kind == "finite_number":
            text = "must be a finite number (not nan or inf)"
        elif kind == "less_than_equal" and loc[0] == "stage2_share":
            text = "is a share of the episodes; fix: give a number from 0 to 1"
        else:
            text = err["msg"].removeprefix("Value error, ")
        out.append(f"{name} = {value!r} {text}")
    return out
