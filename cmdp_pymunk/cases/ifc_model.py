"""The IFC import's reading of a model: opening it, and a storey's elements with their plan
footprints (IfcOpenShell's side of ``cases.ifc_import``).

:func:`open_model` opens an IFC file or says why it cannot. :func:`storey_elements` takes the
storey's elements of the recipe's IFC classes (contained or aggregated, in file order), each an
:class:`Element` with its plan footprint: its body's faces projected on the floor, in metres
(:func:`footprint_outline`: the bounding rectangle, the share of it the footprint fills, and
the outline when it is one polygon but no rectangle). An element without a body of its own
takes its footprint from its parts (the elements aggregated to it, which are then no
components: :func:`_body_shapes`). :func:`_component_ids` names the components.

Apart from the storey's level and supports (``ifc_storey``), the model's 4D schedule
(``ifc_schedule``) and the case built from them (``ifc_import``): this is the part that
tessellates geometry. IfcOpenShell is an optional dependency (``pip install -e '.[ifc]'`` in a
checkout, :data:`INSTALL_HINT`), imported only when a function here is called
(:func:`require_ifcopenshell`); the 4D export opens its models here too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .floorplan import GEOMETRY_TOLERANCE_M, Recipe, Rect
from .load import CaseError

# the package is installed from a checkout (it is not on a package index): the extra from there
INSTALL_HINT = "pip install -e '.[ifc]' in the checkout (make test installs it)"


class IfcUnavailable(ImportError):
    """IfcOpenShell is not installed."""


def require_ifcopenshell():
    """The ``ifcopenshell`` module, or :class:`IfcUnavailable` saying how to install it."""
    try:
        import ifcopenshell
        import ifcopenshell.geom  # noqa: F401
        import ifcopenshell.util.element  # noqa: F401
    except ImportError as err:
        raise IfcUnavailable(f"reading and writing IFC needs IfcOpenShell ({err}); fix: "
                             f"{INSTALL_HINT}") from None
    return ifcopenshell


def open_model(path: str | Path):
    """An IFC model, or :class:`CaseError` naming the file and why it cannot be read."""
    ifcopenshell = require_ifcopenshell()
    path = Path(path)
    if not path.is_file():
        raise CaseError(str(path), ["cannot read the file (no such file); fix: check the path"])
    with path.open("rb") as f:
        head = f.read(64)
    if not head.lstrip().startswith(b"ISO-10303-21"):
        raise CaseError(path.name, ["is not an IFC file (an IFC-SPF file starts with "
                                    "'ISO-10303-21;'); fix: export the model as .ifc"])
    try:
        return ifcopenshell.open(str(path))
    except Exception as err:  # ifcopenshell raises its own error types, or RuntimeError
        raise CaseError(path.name, [f"cannot be read as IFC ({err}); fix: check the file in a "
                                    "BIM viewer and export it again"]) from None


@dataclass(frozen=True)
class Element:
    """An element of the storey that the recipe takes, with its plan footprint (metres,
    the model's world coordinates)."""

    guid: str
    ifc_class: str
    name: str
    kind: str
    rect: Rect | None  # the footprint's bounding rectangle; None: no body geometry
    fill: float  # footprint area / rectangle area
    z_m: tuple[float, float] | None = None  # the body's bottom and top (world z, metres)
    classes: tuple[str, ...] = ()  # its class and superclasses, most specific first
    parts_from: tuple[str, ...] = ()  # the classes of the parts its body came from, if any
    outline: tuple | None = None  # its footprint's corners when no rectangle (world, m)

    @property
    def label(self) -> str:
        return f'{self.ifc_class} "{self.name}" ({self.guid})'


def _class_chain(element) -> list[str]:
    """The element's class and its superclasses, most specific first."""
    from ifcopenshell import ifcopenshell_wrapper

    schema = element.is_a(True).split(".")[0]
    decl = ifcopenshell_wrapper.schema_by_name(schema).declaration_by_name(element.is_a())
    chain = []
    while decl is not None:
        chain.append(decl.name())
        decl = decl.supertype()
    return chain


def footprint(shapes) -> tuple[Rect | None, float]:
    """The plan footprint of tessellated shapes (one, or a sequence: an element's parts;
    world coordinates, metres): its bounding rectangle and the share of that rectangle the
    footprint fills (the union of the triangles' projections on the floor)."""
    rect, fill, _ = footprint_outline(shapes)
    return rect, fill


def footprint_outline(shapes) -> tuple[Rect | None, float, tuple | None]:
    """``footprint``'s rectangle and fill, and the footprint's projected outline: the union of
    the body's projected faces simplified within ``GEOMETRY_TOLERANCE_M``, as its corners
    (world, metres), when it is one polygon without holes that its rectangle does not fill
    (a notched, trapezoidal or L-shaped slab); None for a rectangle (or a footprint of
    several pieces or with holes: those are boxed, ``[import] min_fill``)."""
    import numpy as np
    import shapely

    shapes = shapes if isinstance(shapes, (list, tuple)) else [shapes]
    verts = [np.asarray(s.geometry.verts, dtype=float).reshape(-1, 3) for s in shapes]
    faces = [np.asarray(s.geometry.faces, dtype=int).reshape(-1, 3) for s in shapes]
    tris = [v[f][:, :, :2] for v, f in zip(verts, faces, strict=True) if len(f)]  # (n, 3, 2)
    verts = np.concatenate(verts) if verts else np.zeros((0, 3))
    if len(verts) == 0:
        return None, 0.0
    tris = np.concatenate(tris) if tris else np.zeros((0, 3, 2))
    cross = ((tris[:, 1, 0] - tris[:, 0, 0]) * (tris[:, 2, 1] - tris[:, 0, 1])
             - (tris[:, 1, 1] - tris[:, 0, 1]) * (tris[:, 2, 0] - tris[:, 0, 0]))
    tris = tris[np.abs(cross) > 1e-9]  # faces seen edge-on from above add no area
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    rect = Rect(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    if len(tris) == 0 or rect.area <= 0:
        return rect, 0.0, None
    # the faces' union, its slivers between triangles closed within the tolerance
    union = shapely.union_all(shapely.polygons(tris))
    fill = min(1.0, union.area / rect.area)
    shape = union.buffer(GEOMETRY_TOLERANCE_M / 2, join_style="mitre").buffer(
        -GEOMETRY_TOLERANCE_M / 2, join_style="mitre").simplify(GEOMETRY_TOLERANCE_M)
    if fill >= 0.999 or shape.geom_type != "Polygon" or shape.interiors:
        return rect, fill, None
    return rect, fill, tuple(shape.exterior.coords[:-1])


def _body_shapes(element, settings) -> tuple[list, list]:
    """The tessellated body of an element (world coordinates, metres: IfcOpenShell converts
    the model's length unit, and takes the body in whatever context it is modelled, 'Body' or
    'Plan'), and the parts it came from. An element without a body of its own (no
    representation, or only an axis or a box) takes its parts' bodies: the elements aggregated
    to it (IfcRelAggregates), as precast detailing tools write a slab whose body sits on a
    proxy; a part without a body takes its own parts'."""
    import ifcopenshell.geom
    import ifcopenshell.util.element

    if element.Representation is not None:
        try:
            shape = ifcopenshell.geom.create_shape(settings, element)
        except RuntimeError:  # no body: an axis, a bounding box, nothing to tessellate
            shape = None
        if shape is not None and len(shape.geometry.verts):
            return [shape], []
    shapes, parts = [], []
    for part in ifcopenshell.util.element.get_parts(element) or []:
        if not part.is_a("IfcElement"):
            continue
        got, below = _body_shapes(part, settings)
        if got:
            shapes += got
            parts += [part, *below]
    return shapes, parts


def storey_elements(model, storey, recipe: Recipe) -> tuple[list[Element], dict[str, int]]:
    """The storey's elements that the recipe takes (contained or aggregated, in file order)
    with their footprints, and a count of the element classes it skipped. An element without
    a body of its own takes its footprint from its parts (:func:`_body_shapes`); those parts
    are neither components nor skipped."""
    import ifcopenshell.geom
    import ifcopenshell.util.element

    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    taken, not_taken = [], []
    decomposed = ifcopenshell.util.element.get_decomposition(storey)
    for element in sorted(decomposed, key=lambda e: e.id()):
        if not element.is_a("IfcElement"):
            continue
        chain = _class_chain(element)
        kind = recipe.kind_of(chain, ifcopenshell.util.element.get_predefined_type(element))
        if kind is None:
            not_taken.append(element)
            continue
        shapes, parts = _body_shapes(element, settings)
        taken.append((element, chain, kind, shapes, parts))
    in_others = {part.id(): part for *_, parts in taken for part in parts}
    elements = []
    for element, chain, kind, shapes, parts in taken:
        if element.id() in in_others:
            continue  # a part of an element taken whole
        rect, fill, z, outline = None, 0.0, None, None
        if shapes:
            rect, fill, outline = footprint_outline(shapes)
            heights = [h for s in shapes for h in s.geometry.verts[2::3]]
            z = (min(heights), max(heights))
        elements.append(Element(element.GlobalId, element.is_a(), (element.Name or "").strip(),
                                kind, rect, fill, z, tuple(chain),
                                tuple(sorted({p.is_a() for p in parts})), outline))
    skipped: dict[str, int] = {}
    for element in not_taken:
        if element.id() not in in_others:
            skipped[element.is_a()] = skipped.get(element.is_a(), 0) + 1
    return elements, skipped


def _component_ids(elements: Sequence[Element]) -> list[str]:
    """Each element's Name where it is unique among the elements, else ``Slab-3``."""
    counts: dict[str, int] = {}
    for e in elements:
        counts[e.name] = counts.get(e.name, 0) + 1
    taken = {e.name for e in elements if e.name and counts[e.name] == 1}
    ids, numbered = [], {}
    for e in elements:
        if e.name and counts[e.name] == 1:
            ids.append(e.name)
            continue
        stem = e.ifc_class.removeprefix("Ifc")
        while True:
            numbered[stem] = numbered.get(stem, 0) + 1
            candidate = f"{stem}-{numbered[stem]}"
            if candidate not in taken:
                break
        taken.add(candidate)
        ids.append(candidate)
    return ids
