"""The logistics role: when a crew that fetches asks for a storage's next crane lift.

In the paper a storage's next lift is asked for only once it is empty (Table 1's c7: the crew
that finds it so waits for the lift). A case's reorder point (``Material.reorder_at``) asks
earlier, by a fixed rule. This module makes the question a role of its own, injected into the
engine like the evaluator (``Engine(case, ..., logistics=...)``), so a rule or a learned
policy decides from the floor's state. Every implementation meets the engine at one protocol,
``Logistics``:

- ``levels(material) -> (stock, ...)``: the decision levels (in the material's unit). A crew
  fetching at a storage is asked once at each level its storage's stock falls to, with stock
  left and no lift asked for, and asked at every level again once a lift lands
  (``construct.decision_level``). The event floor stops its span at the second a level is
  reached (``construct.next_change_in``), so both floors ask at the same second;
- ``lift_now(engine, i, storage) -> bool``: whether crew i, fetching at storage index
  ``storage``, asks for the next lift now (``construct.order_lift``, the request a reorder
  point makes); "no" lets the stock run on to the next level, or empty (c7);
- ``prepare(case)``: called once the role is given to an engine: check that it fits the case
  (a ``ValueError`` naming the fix) and resolve what depends on it.

``logistics=None`` (every engine's default) keeps the case's reorder point as the rule, which
is the paper's c7 alone where the case sets none. An injected role replaces the case's reorder
point. Like an evaluator, a role is shared by an engine's clones: it keeps no per-episode
state of its own (what was asked is the site's, ``StorageState.asked_at``).

Four roles ship: ``Never`` (the paper's c7: never asks early), ``ReorderPoint`` (a fixed
reorder point as a role: the same schedule as the case's ``reorder_at``), ``CraneIdle`` (a
state rule: lift now when the crane has nothing to do) and ``Learned`` (a linear rule over the
floor's state read from a model file, ``models/logistics_learned.json``, fitted by
``training.research.logistics_search``). ``FromOutside`` leaves the answer to a caller (the
stage-2 decision loop's logistics decisions, ``adapters.decision_loop``).

``from_spec`` turns a command's ``--logistics SPEC`` (``case``, ``never``, ``reorder:LIFTS``,
``crane-idle``, ``learned:PATH``) into a role, refusing a bad spec with the fix; it is the one
parser of those names (``cmdp-simulate``, ``cmdp-evaluate``, the benchmarks).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from .jsonfile import read_json, require_entry
from .state import CrewStatus

if TYPE_CHECKING:
    from .cases.model import Case
    from .engine import Engine


@runtime_checkable
class Logistics(Protocol):
    """When a fetching crew asks for the next lift (see the module doc)."""

    def prepare(self, case: Case) -> None:
        """Fit ``case`` (a ``ValueError`` naming the fix if it cannot); once per engine."""

    def levels(self, material: str) -> tuple[float, ...]:
        """The stock levels of ``material`` (its unit) at which a fetching crew is asked."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        """Whether crew i, fetching at storage ``storage``, asks for the next lift now."""


def _check_materials(case: Case, named, who: str) -> None:
    unknown = sorted(set(named) - set(case.materials))
    if unknown:
        raise ValueError(f"{who}: no material {', '.join(map(repr, unknown))} in case "
                         f"{case.case.name!r}; fix: name one of "
                         f"{', '.join(sorted(case.materials))}")


class Never:
    """Never asks early: a storage's lift is asked for once it is empty (c7), the paper's
    logistics. Asked nowhere (no levels), so it runs exactly as a case without reorder
    points."""

    def prepare(self, case: Case) -> None:
        return None

    def levels(self, material: str) -> tuple[float, ...]:
        return ()

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        return False


class ReorderPoint:
    """A fixed reorder point as a role: asked once a storage's stock is down to ``at`` (every
    material's, in its unit; or ``{material: stock}``, the others never early), it always asks
    for the next lift. The same schedule as the case with ``Material.reorder_at`` = ``at``
    (``tests/test_logistics.py``). ``lifts``: ``at`` in crane lifts of each material instead
    (0.5: half a lift, the reorder floor's point)."""

    def __init__(self, at: float | Mapping[str, float] | None = None, *,
                 lifts: float | None = None):
        if (at is None) == (lifts is None):
            raise ValueError("ReorderPoint: give the point either as at= (stock, in each "
                             "material's unit) or as lifts= (a share of its crane lift), "
                             "e.g. ReorderPoint(lifts=0.5)")
        given = lifts if at is None else at
        values = given.values() if isinstance(given, Mapping) else (given,)
        if any(not (math.isfinite(v) and v >= 0.0) for v in values):
            raise ValueError(f"ReorderPoint: {given!r} holds a point below 0 or not finite; "
                             "fix: a stock of 0 or more (0: never early)")
        self.at, self.lifts = at, lifts
        self._points: dict[str, float] = {}

    def prepare(self, case: Case) -> None:
        if isinstance(self.at, Mapping):
            _check_materials(case, self.at, "ReorderPoint")
            self._points = {m: float(self.at.get(m, 0.0)) for m in case.materials}
        elif self.at is not None:
            self._points = dict.fromkeys(case.materials, float(self.at))
        else:
            self._points = {m: self.lifts * x.crane_lift_quantity
                            for m, x in case.materials.items()}

    def levels(self, material: str) -> tuple[float, ...]:
        at = self._points.get(material, 0.0)
        return (at,) if at > 0.0 else ()  # 0: no reorder point, as Material.reorder_at

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        return True


class Levels:
    """Decision levels as shares of each material's crane lift (``shares``; (0.75, 0.5,
    0.25): a quarter of a lift apart), resolved for the case in ``prepare``; what a role
    that decides from the floor's state is asked at. Subclass it and write ``lift_now``."""

    def __init__(self, shares: tuple[float, ...] = (0.75, 0.5, 0.25)):
        if not shares or any(not (math.isfinite(s) and s > 0.0) for s in shares):
            raise ValueError(f"{type(self).__name__}: decision levels {shares!r}; fix: one or "
                             "more shares of a crane lift above 0, e.g. (0.75, 0.5, 0.25)")
        self.shares = tuple(sorted(shares, reverse=True))
        self._levels: dict[str, tuple[float, ...]] = {}

    def prepare(self, case: Case) -> None:
        self._levels = {m: tuple(s * x.crane_lift_quantity for s in self.shares)
                        for m, x in case.materials.items()}

    def levels(self, material: str) -> tuple[float, ...]:
        return self._levels.get(material, ())

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        raise NotImplementedError(f"{type(self).__name__}.lift_now(engine, i, storage)")


class CraneIdle(Levels):
    """A state rule: at each decision level, ask for the next lift when the crane has nothing
    under way and nothing queued (a lift now delays no other request); otherwise let the stock
    run on to the next level, or empty (c7)."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        crane = engine.site.crane
        return crane.current is None and not crane.queue


class FromOutside(Levels):
    """The answer comes from outside the engine (the stage-2 decision loop's policy): asked,
    it records the question in ``engine.lift_questions`` and says "not yet"; the engine's
    ``advance`` stops after the span, and the caller answers each question with
    ``engine.answer_lift(i, lift)`` before the next one runs (a "yes" asks for the lift at the
    same second; "no" for every question is ``Never``'s schedule)."""

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        engine.lift_questions.append((i, storage))
        return False


# -- the learned role ------------------------------------------------------------------------

_FETCHING = CrewStatus.FETCHING  # bound once: an enum lookup per call costs (PITFALLS)


def _stock_lifts(engine: Engine, i: int, storage: int) -> float:
    s = engine.site.storages[storage]
    return s.stock / engine.case.materials[s.material].crane_lift_quantity


def _crane_busy(engine: Engine, i: int, storage: int) -> float:
    return float(engine.site.crane.current is not None)


def _crane_queue(engine: Engine, i: int, storage: int) -> float:
    return float(len(engine.site.crane.queue))


def _crane_left_lifts(engine: Engine, i: int, storage: int) -> float:
    crane = engine.site.crane
    return 0.0 if crane.current is None else crane.remaining_s / engine.case.crane.lift_time_s


def _fetching_here(engine: Engine, i: int, storage: int) -> float:
    return float(sum(c.status == _FETCHING and c.storage == storage
                     for c in engine.site.crews))


def _progress(engine: Engine, i: int, storage: int) -> float:
    site = engine.site
    return site.tasks_ended / len(site.tasks)


# What a ``Learned`` rule may read, each a number of the floor's state at the decision (crew
# i fetching at storage index ``storage``), about 0-1 in size so that one step size fits all
# weights in the search. ``material=<name>`` (1 for that material's storage, else 0) is
# resolved against the case in ``prepare``.
LEARNED_FEATURES: dict[str, Callable[[Engine, int, int], float]] = {
    "stock_lifts": _stock_lifts,            # the storage's stock in crane lifts of its material
    "crane_busy": _crane_busy,              # 1: a lift or hoisting under way
    "crane_queue": _crane_queue,            # requests waiting behind it
    "crane_left_lifts": _crane_left_lifts,  # what is left of the one under way, in lift times
    "fetching_here": _fetching_here,        # crews loading at this storage (its drain)
    "progress": _progress,                  # share of the floor's tasks ended
}
MATERIAL_FEATURE = "material="
LEARNED_KIND = "cmdp-logistics-linear"


def _material_feature(material: str) -> Callable[[Engine, int, int], float]:
    def read(engine: Engine, i: int, storage: int) -> float:
        return float(engine.site.storages[storage].material == material)
    return read


def linear_lift(weights: tuple[float, ...], bias: float, features: tuple[float, ...]) -> bool:
    """The learned rule's answer: lift now when ``bias + sum(w * phi) > 0`` (the decision
    boundary of a logistic model, p(lift) > 1/2)."""
    return bias + math.fsum(w * x for w, x in zip(weights, features, strict=True)) > 0.0


class Learned(Levels):
    """A linear rule fitted to the floor (``training.research.logistics_search``): at each
    decision level (``shares`` of a crane lift, from the file) crew i asks for the next lift
    when ``bias + w . phi > 0`` over the named features (``LEARNED_FEATURES``, and
    ``material=<name>``) of the floor's state. ``path``: the model file (JSON: ``kind``
    "cmdp-logistics-linear", ``features``, ``weights``, ``bias``, ``shares``, ``meta``); a bad
    file fails here, naming the file, the entry and the fix. Keeps no per-episode state."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        data = _read_model(self.path)
        super().__init__(tuple(data["shares"]))
        self.features: tuple[str, ...] = tuple(data["features"])
        self.weights: tuple[float, ...] = tuple(float(w) for w in data["weights"])
        self.bias = float(data["bias"])
        self.meta = data.get("meta", {})
        self._readers: tuple[Callable[[Engine, int, int], float], ...] = ()

    @classmethod
    def from_weights(cls, features, weights, bias: float,
                     shares: tuple[float, ...] = (0.75, 0.5, 0.25)) -> Learned:
        """A rule from its numbers, without a file (what the search tries)."""
        self = cls.__new__(cls)
        Levels.__init__(self, tuple(shares))
        self.path, self.meta = Path("<weights>"), {}
        self.features, self.weights = tuple(features), tuple(float(w) for w in weights)
        self.bias = float(bias)
        _check_model({"features": list(self.features), "weights": list(self.weights),
                      "bias": self.bias, "shares": list(shares)}, self.path)
        self._readers = ()
        return self

    def prepare(self, case: Case) -> None:
        super().prepare(case)
        named = [f[len(MATERIAL_FEATURE):] for f in self.features
                 if f.startswith(MATERIAL_FEATURE)]
        unknown = sorted(set(named) - set(case.materials))
        if unknown:
            raise ValueError(f"{self.path}: features name material(s) "
                             f"{', '.join(map(repr, unknown))}, not in case {case.case.name!r}; "
                             "fix: "
                             f"fit the rule on this case (materials "
                             f"{', '.join(sorted(case.materials))})")
        self._readers = tuple(
            _material_feature(f[len(MATERIAL_FEATURE):]) if f.startswith(MATERIAL_FEATURE)
            else LEARNED_FEATURES[f] for f in self.features)

    def feature_values(self, engine: Engine, i: int, storage: int) -> tuple[float, ...]:
        """phi at this decision, in ``features`` order."""
        return tuple(read(engine, i, storage) for read in self._readers)

    def lift_now(self, engine: Engine, i: int, storage: int) -> bool:
        return linear_lift(self.weights, self.bias, self.feature_values(engine, i, storage))

    def to_json(self, meta: dict | None = None) -> str:
        """The model file's text (what ``Learned(path)`` reads)."""
        return json.dumps({"kind": LEARNED_KIND, "features": list(self.features),
                           "weights": list(self.weights), "bias": self.bias,
                           "shares": list(self.shares), "meta": meta or self.meta},
                          indent=2) + "\n"


def _read_model(path: Path) -> dict:
    fix = "give a logistics model file written by training.research.logistics_search, e.g. " \
        "models/logistics_learned.json"
    data = read_json(path, "logistics model file", fix)
    require_entry(data, path, "kind", LEARNED_KIND, fix)
    _check_model(data, path)
    return data


def _check_model(data: dict, path: Path) -> None:
    """Every problem of a model's numbers at once, each naming the entry and the fix."""
    problems = []
    for key in ("features", "weights", "bias", "shares"):
        if key not in data:
            problems.append(f"entry {key!r} is missing; fix: write it (see logistics.Learned)")
    if problems:
        raise ValueError(f"{path}: " + "; ".join(problems))
    features, weights = data["features"], data["weights"]
    if not isinstance(features, list) or not isinstance(weights, list):
        raise ValueError(f"{path}: entries 'features' and 'weights' must be lists; fix: one "
                         "weight per feature name")
    for k, name in enumerate(features):
        if not (isinstance(name, str) and (name in LEARNED_FEATURES or
                                           name.startswith(MATERIAL_FEATURE))):
            problems.append(f"features[{k}] {name!r} is no feature; fix: one of "
                            f"{', '.join(LEARNED_FEATURES)} or material=<name>")
    if len(weights) != len(features):
        problems.append(f"'weights' has {len(weights)} numbers for {len(features)} features; "
                        "fix: one weight per feature")
    for k, w in enumerate([*weights, data["bias"]]):
        entry = f"weights[{k}]" if k < len(weights) else "bias"
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not math.isfinite(w):
            problems.append(f"{entry} {w!r} is not a finite number; fix: a finite number")
    shares = data["shares"]
    if not isinstance(shares, list) or not shares or any(
            isinstance(s, bool) or not isinstance(s, (int, float)) or not
            (math.isfinite(s) and s > 0.0) for s in shares):
        problems.append(f"'shares' {shares!r}; fix: one or more shares of a crane lift above "
                        "0, e.g. [0.75, 0.5, 0.25]")
    if problems:
        raise ValueError(f"{path}: " + "; ".join(problems))


def make_logistics(spec: Logistics | None) -> Logistics | None:
    """``spec`` itself if it is a ``Logistics`` (or None: the case's reorder point decides);
    otherwise a ``TypeError`` naming the members a role needs."""
    if spec is None or isinstance(spec, Logistics):
        return spec
    raise TypeError(f"logistics {spec!r} is not a logistics role; fix: give a "
                    "logistics.Logistics (prepare(case), levels(material), lift_now(engine, i, "
                    "storage)), e.g. logistics.Never() or logistics.ReorderPoint(lifts=0.5), "
                    "or None for the case's reorder point")


# ``--logistics SPEC`` of the commands (``from_spec``): the forms, for the help and the errors
LOGISTICS_SPECS = ("case", "never", "reorder:LIFTS", "crane-idle", "learned:PATH")
LOGISTICS_HELP = ("who decides when a fetching crew asks for the next crane lift: case (the "
                  "case's reorder point, none if it sets none; default), never (the paper's "
                  "c7: a lift once a storage is empty), reorder:LIFTS (a reorder point at LIFTS "
                  "crane lifts of each material, e.g. reorder:0.5), crane-idle (at a quarter "
                  "of a lift apart, when the crane has nothing to do) or learned:PATH (a "
                  "linear rule's model file, e.g. learned:models/logistics_learned.json)")
SHIPPED_LEARNED = "models/logistics_learned.json"  # the rule the repository ships


def from_spec(spec: str, option: str = "--logistics", case: Case | None = None
              ) -> Logistics | None:
    """The logistics role a command-line spec names (``LOGISTICS_SPECS``): ``case`` -> None
    (the case's reorder point decides: the engine's default), ``never`` -> ``Never``,
    ``reorder:LIFTS`` -> ``ReorderPoint(lifts=LIFTS)``, ``crane-idle`` -> ``CraneIdle``,
    ``learned:PATH`` -> ``Learned(PATH)`` (the file read and checked now). A bad spec: a
    ValueError naming ``option``, the spec and the fix, before anything runs. ``case``: also
    check that the role fits it (its ``prepare``, e.g. a model naming another case's
    materials), the same way."""
    where = f"{option} {spec!r}" if option else repr(spec)  # argparse names the option itself
    role = _role_of(spec, where, option)
    if role is not None and case is not None:
        try:
            role.prepare(case)
        except ValueError as err:
            raise ValueError(f"{where}: {err}") from None
    return role


def _role_of(spec: str, where: str, option: str) -> Logistics | None:
    import difflib

    name, sep, value = spec.partition(":")
    if name == "reorder" and sep:
        try:
            lifts = float(value)
        except ValueError:
            lifts = math.nan
        if not (math.isfinite(lifts) and lifts >= 0.0):
            raise ValueError(f"{where}: LIFTS {value!r} is not a number of 0 or more; fix: a "
                             "share of each material's crane lift, e.g. reorder:0.5 (0: never "
                             "early)")
        return ReorderPoint(lifts=lifts)
    if name == "learned" and sep:
        if not value:
            raise ValueError(f"{where}: no model file after 'learned:'; fix: e.g. "
                             f"learned:{SHIPPED_LEARNED}")
        try:
            return Learned(value)
        except (OSError, ValueError) as err:  # the file's own message names entry and fix
            raise ValueError(f"{where}: {err}") from None
    if not sep:
        plain = {"case": None, "never": Never, "crane-idle": CraneIdle}
        if spec in plain:
            role = plain[spec]
            return None if role is None else role()
        if spec in ("reorder", "learned"):
            example = "reorder:0.5" if spec == "reorder" else f"learned:{SHIPPED_LEARNED}"
            raise ValueError(f"{where} needs its {'LIFTS' if spec == 'reorder' else 'PATH'}; "
                             f"fix: e.g. {option + ' ' if option else ''}{example}")
    close = difflib.get_close_matches(name, ["case", "never", "reorder", "crane-idle",
                                             "learned"], n=1)
    hint = f"did you mean {close[0]!r}? " if close else ""
    raise ValueError(f"{where} is no logistics role; {hint}fix: one of "
                     f"{', '.join(LOGISTICS_SPECS)}")


__all__ = ["Logistics", "Never", "ReorderPoint", "Levels", "CraneIdle", "FromOutside",
           "Learned", "LEARNED_FEATURES", "linear_lift", "make_logistics",
           "from_spec", "LOGISTICS_SPECS", "LOGISTICS_HELP"]
