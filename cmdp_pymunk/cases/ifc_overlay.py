"""The IFC import's overlay: what an IFC model does not say, read from a small TOML beside it
(``cmdp-import-ifc --overlay``, docs/ifc.md) and checked.

Crews, crane, storages and the plane's margin come from the overlay (:data:`DEFAULT_OVERLAY`
where it gives none); task types, crew types and materials from the built-in case unless the
overlay gives its own; the recipe (which IFC class is which kind of component, and each
kind's chain of tasks) is ``floorplan.PRECAST_RECIPE`` unless it gives ``[recipe]``.
:func:`load_overlay` merges it over the defaults and reports every problem together, naming
the file, before any model is opened; :class:`Overlay` is the result, with where each setting
came from (``Overlay.provenance``).

Apart from the model's side (``ifc_model``, ``ifc_storey``, ``ifc_schedule``) and the case
built from them (``ifc_import``): it reads only TOML, so it needs no IfcOpenShell, and the
overlay files are checked without the [ifc] extra.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .floorplan import PRECAST_RECIPE, Recipe, Step
from .load import BUILTIN_CASE, CaseError, _did_you_mean, _read_toml

# The overlay's defaults fit the built-in case: its crews (Table 3's seven), its storages
# (rebars and templates on the top edge, struts on the bottom edge) and its margins (6 m of
# open floor left and right of the components, 7 m above and below).
DEFAULT_OVERLAY: dict = {
    "plane": {"margin_x_m": 6.0, "margin_y_m": 7.0},
    # polygons: an element whose footprint is one polygon but no rectangle (notched,
    # trapezoidal, L-shaped) is imported as drawn (a component's outline); false: boxed,
    # refused below min_fill as before polygons
    "import": {"min_fill": 0.9, "neighbour_gap_m": 5.0, "check_storey": True,
               "polygons": True,
               # elements of these classes whose body lies wholly below the storey's level
               # carry the floor (beams and columns under the slabs, the walls of the storey
               # below): supports, not obstacles on the work plane (``ifc_storey.split_supports``)
               "supports": ["IfcBeam", "IfcColumn", "IfcWall", "IfcMember"],
               # slabs side by side with joints this narrow form a deck, walked on once
               # laid (``ifc_storey.deck_slabs``)
               "deck_joint_max_m": 0.1},
               # no "level_m": the storey's level comes from the model unless the overlay
               # gives one (``ifc_levels.working_level``)
    "crews": {"JCC": 1, "HIC": 1, "GC": 1, "RC": 2, "FC": 2},
    "crane": {"lift_time_s": 240.0, "assist_time_s": 180.0},
    # x_frac: where along the edge, -1 (left wall) to 1 (right wall)
    "storages": [
        {"id": "ST-rebars", "material": "rebars", "width_m": 6.0, "height_m": 3.0,
         "capacity": 3.0, "congestion_index_full": 0.5, "edge": "top", "x_frac": -4 / 9},
        {"id": "ST-templates", "material": "templates", "width_m": 6.0, "height_m": 3.0,
         "capacity": 80.0, "congestion_index_full": 0.5, "edge": "top", "x_frac": 4 / 9},
        {"id": "ST-struts", "material": "struts", "width_m": 5.0, "height_m": 3.0,
         "capacity": 12.0, "congestion_index_full": 0.6, "edge": "bottom", "x_frac": 0.0},
    ],
}
_OVERLAY_SECTIONS = {"plane", "import", "crews", "crane", "storages", "recipe", "case",
                     "simulation", "reaching_reward", "task_types", "crew_types", "materials"}
_OVERLAY_KEYS = {"plane": ("margin_x_m", "margin_y_m", "width_m", "height_m"),
                 "import": ("min_fill", "neighbour_gap_m", "check_storey", "polygons",
                            "supports",
                            "deck_joint_max_m", "level_m"),
                 "crane": ("lift_time_s", "assist_time_s")}
_STORAGE_KEYS = ("id", "material", "width_m", "height_m", "capacity", "congestion_index_full",
                 "edge", "x_frac")


@dataclass(frozen=True)
class Overlay:
    """What the IFC model does not say: crews, crane, storages, margins, the recipe, and
    the case's tables (task types, crew types, materials, simulation), resolved."""

    data: dict  # the merged overlay, defaults filled in
    recipe: Recipe
    base: dict  # the built-in case's tables, overridden by the overlay's
    source: str
    given: frozenset = frozenset()  # the sections the overlay file gave (the rest: defaults)

    def provenance(self) -> dict[str, str]:
        """Where each setting the model does not hold came from: "overlay FILE" for a section
        the overlay gave (merged over the defaults for plane, import and crane), "default"
        for the rest (DEFAULT_OVERLAY; the built-in case's tables; the precast recipe)."""
        return {section: (f"overlay {self.source}" if section in self.given else "default")
                for section in sorted(_OVERLAY_SECTIONS)}


def _recipe_from(data: dict | None, source: str, problems: list[str]) -> Recipe:
    if data is None:
        return PRECAST_RECIPE
    if not isinstance(data, dict) or not isinstance(data.get("chains"), dict) \
            or not isinstance(data.get("classes", {}), dict):
        problems.append("recipe: needs [recipe.classes] (IFC class = kind) and "
                        "[recipe.chains] (kind = [{type = ...}, ...]); fix: see docs/ifc.md")
        return PRECAST_RECIPE
    chains: dict[str, tuple[Step, ...]] = {}
    for kind, steps in data["chains"].items():
        if not isinstance(steps, list):
            problems.append(f"recipe.chains.{kind}: write a list of steps, e.g. "
                            '[{type = "JC"}, {type = "HI"}]')
            continue
        built = []
        for k, step in enumerate(steps):
            known = {"type", "work", "material_quantity", "after_neighbours"}
            if not isinstance(step, dict) or not isinstance(step.get("type"), str) \
                    or set(step) - known:
                problems.append(f"recipe.chains.{kind}[{k}]: a step is a table with type and "
                                "optionally work, material_quantity, after_neighbours; fix: "
                                'e.g. {type = "R", work = 0.5, after_neighbours = "HI"}')
                continue
            built.append(Step(step["type"], step.get("work"),
                              float(step.get("material_quantity", 0.0)),
                              step.get("after_neighbours")))
        chains[kind] = tuple(built)
    for key in set(data) - {"classes", "chains"}:
        problems.append(f"recipe.{key}: unknown field; fix: the recipe has classes and chains "
                        "(the neighbours' distance is import.neighbour_gap_m)")
    return Recipe(chains=chains, classes=dict(data.get("classes", PRECAST_RECIPE.classes)))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def load_overlay(path: str | Path | None = None) -> Overlay:
    """The overlay TOML merged over :data:`DEFAULT_OVERLAY` and the built-in case's tables,
    checked: every problem reported together in one :class:`CaseError` naming the file."""
    source = Path(path).name if path is not None else "the default overlay"
    # read as a case file is: one wording for an unreadable file and a syntax error in both
    raw: dict = _read_toml(Path(path)) if path is not None else {}
    problems = [f"[{k}]: unknown section; fix: use one of "
                + ", ".join(sorted(_OVERLAY_SECTIONS)) for k in raw if k not in _OVERLAY_SECTIONS]
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in DEFAULT_OVERLAY.items()}
    for key in ("plane", "import", "crane"):
        if isinstance(raw.get(key), dict):
            data[key] = {**data[key], **raw[key]}
    for key in ("crews", "storages", "case"):
        if key in raw:
            data[key] = raw[key]
    base_toml = tomllib.loads(BUILTIN_CASE.read_text(encoding="utf-8"))
    base = {k: raw.get(k, base_toml[k]) for k in ("simulation", "reaching_reward", "task_types",
                                                   "crew_types", "materials")}
    recipe = _recipe_from(raw.get("recipe"), source, problems)
    gap = data["import"]["neighbour_gap_m"]
    if _is_number(gap):
        recipe = Recipe(recipe.chains, recipe.classes, float(gap))

    problems += _field_problems(data)
    problems += _storage_problems(data)
    if _is_number(data["import"]["min_fill"]) and not 0 <= data["import"]["min_fill"] <= 1:
        problems.append("import.min_fill: a share of the rectangle, from 0 to 1; fix: e.g. 0.9")
    crew_types = base["crew_types"] if isinstance(base["crew_types"], dict) else {}
    task_types = base["task_types"] if isinstance(base["task_types"], dict) else {}
    problems += _crew_problems(data, crew_types)
    problems += _recipe_problems(recipe, task_types, crew_types)
    if problems:
        raise CaseError(source, problems)
    return Overlay(data=data, recipe=recipe, base=base, source=source,
                   given=frozenset(k for k in raw if k in _OVERLAY_SECTIONS))


def _field_problems(data: dict) -> list[str]:
    """Each field of the plane, import and crane sections: known, and a number of 0 or more
    (true or false, a level, IFC classes where the field asks for those)."""
    problems = []
    for section, value in data.items():
        if section == "storages":
            continue
        allowed = _OVERLAY_KEYS.get(section)
        if allowed is None:
            continue
        for key in value:
            if key not in allowed:
                problems.append(f"{section}.{key}: unknown field"
                                + _did_you_mean(key, list(allowed)))
            elif key in ("check_storey", "polygons"):
                if not isinstance(value[key], bool):
                    problems.append(f"{section}.{key} = {value[key]!r}: write true or false")
            elif key == "level_m":  # a height, below the model's origin too (a basement)
                if not _is_number(value[key]):
                    problems.append(f"{section}.{key} = {value[key]!r}: write the storey's "
                                    "level in metres, a number (e.g. 3.0, or -3.0 below the "
                                    "model's origin)")
            elif key == "supports":
                classes = value[key]
                if not isinstance(classes, list) or not all(
                        isinstance(c, str) and re.fullmatch(r"Ifc\w+", c) for c in classes):
                    problems.append(f"{section}.{key} = {classes!r}: write a list of IFC "
                                    "classes whose elements below the storey's level carry "
                                    'it, e.g. ["IfcBeam", "IfcColumn"], or [] for none')
            elif not _is_number(value[key]) or value[key] < 0:
                problems.append(f"{section}.{key} = {value[key]!r}: write a number of 0 or "
                                "more")
    return problems


def _storage_problems(data: dict) -> list[str]:
    """The storages: a list of tables with their fields, an edge and a place along it (an
    unusable section is replaced by none, so that the rest can be checked)."""
    problems = []
    if not isinstance(data["storages"], list):
        problems.append("storages: write [[storages]] entries; fix: see docs/ifc.md")
        data["storages"] = []
    for k, st in enumerate(data["storages"]):
        where = f"storages[{k}]"
        if not isinstance(st, dict):
            problems.append(f"{where}: write a table; fix: see docs/ifc.md")
            continue
        for key in ("id", "material", "width_m", "height_m", "capacity"):
            if key not in st:
                problems.append(f"{where}: {key} missing; fix: add {key} = ...")
        for key in st:
            if key not in _STORAGE_KEYS:
                problems.append(f"{where}: {key}: unknown field"
                                + _did_you_mean(key, list(_STORAGE_KEYS)))
        if st.get("edge", "top") not in ("top", "bottom"):
            problems.append(f'{where}: edge = {st["edge"]!r}; fix: write "top" or "bottom"')
        if not _is_number(st.get("x_frac", 0.0)) or not -1 <= st.get("x_frac", 0.0) <= 1:
            problems.append(f"{where}: x_frac = {st['x_frac']!r}; fix: a number from -1 (left "
                            "wall) to 1 (right wall)")
    return problems


def _crew_problems(data: dict, crew_types: dict) -> list[str]:
    """The crews: a table of known crew types and whole counts (an unusable section is
    replaced by none)."""
    problems = []
    if not isinstance(data["crews"], dict):
        problems.append('crews: write a table of crew type = count, e.g. JCC = 1; fix: '
                        "see docs/ifc.md")
        data["crews"] = {}
    for name, count in data["crews"].items():
        if name not in crew_types:
            problems.append(f'crews.{name}: names unknown crew type "{name}"'
                            + _did_you_mean(name, list(crew_types)))
        if not isinstance(count, int) or isinstance(count, bool) or count < 0:
            problems.append(f"crews.{name} = {count!r}: write a whole number of crews")
    return problems


def _recipe_problems(recipe: Recipe, task_types: dict, crew_types: dict) -> list[str]:
    """The recipe's chains name known task types of known crew types; its classes are IFC
    classes (or Class.PREDEFINEDTYPE) mapped to kinds."""
    problems = []
    for kind, steps in recipe.chains.items():
        for k, step in enumerate(steps):
            for label, name in (("type", step.type), ("after_neighbours", step.after_neighbours)):
                if name is None:
                    continue
                if name not in task_types:
                    problems.append(f'recipe.chains.{kind}[{k}]: {label} names unknown task '
                                    f'type "{name}"' + _did_you_mean(name, list(task_types)))
                    continue
                crew_type = task_types[name].get("crew_type")
                if crew_type not in crew_types:
                    problems.append(f'recipe.chains.{kind}[{k}]: task type {name} needs crew '
                                    f'type "{crew_type}", which is not in [crew_types]'
                                    + _did_you_mean(str(crew_type), list(crew_types)))
    for cls, kind in recipe.classes.items():
        if not isinstance(kind, str) or not re.fullmatch(r"Ifc\w+(\.\w+)?", cls):
            problems.append(f'recipe.classes: {cls} = {kind!r}; fix: write an IFC class (or '
                            'Class.PREDEFINEDTYPE) = "kind", e.g. IfcBeam = "cast-in-place"')
    return problems
