"""IFC models built with ``ifcopenshell.api`` for the importer's tests (needs the [ifc] extra).

``two_by_two(schema)``: storey "Level 1" of four precast slabs S-11, S-12 (top row), S-21,
S-22, 2 x 2 m, 10 m apart, with cast-in-place beams between neighbours: B-H1 (between S-11 and
S-12), B-H2 (S-21, S-22), both 2 x 1.2 m, B-V1 (S-11, S-21), B-V2 (S-12, S-22), 1.2 x 2 m. The
model's origin is far from the floor (x 99..111, y 49..61) so the importer must centre it;
the floor's centre (105, 55) becomes the case's origin. A window (not in the recipe) stands
beside the floor; storey "Level 2" holds nothing.

``precast_deck(schema)``: storey "Level 1" as a precast detailing tool writes it: 3 x 3
``IfcSlab`` (``DECK``) with a placement and no shape of their own, each body on an
``IfcBuildingElementProxy`` aggregated to its slab (IfcRelAggregates), in a representation
context of type 'Plan'; lengths in millimetres; the bodies z -0.25..0 (their bottoms below the
storey's level 0). Slabs 3 x 1.2 m, three to a row with joints of 0, 20 and 80 mm (rows 1, 2,
3), the rows 4 m apart; the model at x 200..209.16, y 100..111.6.

``slabs_on_beams(schema)``: storey "Level 1" (level 0) as a structural model: four slabs
(``BEARING``) 6 x 3 m, z 0..0.3, sharing edges, bearing on beams 0.6 m deep under them
(z -0.6..0): three along y under the slabs' x edges and one along x under the joint y = 3,
crossing them; columns 0.4 x 0.4 m at the slabs' corners (z -3.5..0); a wall of the storey
below under the edge y = 0 (z -3..0), all assigned to Level 1; and a wall standing on the
floor (z 0..3) 3 m beside the deck.

``wide_slab_deck(schema)``: storey "Level 1" as a wide-slab floor from a precast detailing
tool: 5 x 5 ``IfcSlab`` "W-rc" (row r from the bottom, column c from the left), 4 x 2.4 m,
70 mm thick (z -0.07..0), each with a placement and its body on an aggregated
``IfcBuildingElementProxy``, lengths in millimetres; side by side with joints of 0, 20, 40, 60
and 80 mm between the slabs of rows 1 to 5 and 50 mm between the rows: one deck, no lane
through it. The model at x 300..320.32, y 200..212.2.

``l_storey(schema)``: storey "Level 1" in an L of hollow-core slabs (``IfcSlab``, 1.2 m wide,
6 m long along y, 200 mm thick, z 0..0.2, joints of 20 mm): eight slabs "H-1".."H-8" along x
from x 0 (the L's foot, y 0..6) and four "H-9".."H-12" from x 0 on them (its leg, y 6.02 ..
12.02); beams 0.4 m wide under the slabs' ends (z -0.5..0) at y 0 and 6.01 (the foot's
width) and 12.02 (the leg's), columns 0.4 x 0.4 m (z -3..0) at the L's six corners.

``raised_storey(schema, elevation_m, placement_m, building_z_m)``: ``slabs_on_beams``' storey
3 m up (slabs z 3..3.3 on crossing beams and columns), the building's only storey, its level
stated by an Elevation, a placement (relative to the building's), both, or neither.

``edge_beam_storey(schema, closed)``: storey "Level 1" (IFC2X3 by default), two rows of three
slabs 4 x 3 m across a 4 m lane, 0.5 m cast-in-place joints between the bottom row's slabs
and a 0.4 m cast-in-place beam on the floor along that row's outer edge (24 tasks); with
``closed``, a second one along its lane edge closes the middle slab's JC area off. The model
at x 400..413, y 299.6..310.
"""

from __future__ import annotations

import numpy as np

SLABS = {"S-11": (100.0, 60.0), "S-12": (110.0, 60.0), "S-21": (100.0, 50.0),
         "S-22": (110.0, 50.0)}
# the deck: slab "D-rc" (row r from the bottom, column c from the left) -> its lower left
# corner (metres); slabs 3 x 1.2 m side by side in a row with joints of 0 (row 1), 20 (row 2)
# and 80 mm (row 3), the rows 4 m apart (lanes for the crews)
DECK_SLAB_M = (3.0, 1.2)
DECK_JOINTS_M = (0.0, 0.02, 0.08)
DECK = {f"D-{r + 1}{c + 1}": (200.0 + c * (3.0 + joint), 100.0 + r * (1.2 + 4.0))
        for r, joint in enumerate(DECK_JOINTS_M) for c in range(3)}
BEAMS = {"B-H1": (105.0, 60.0, 2.0, 1.2), "B-H2": (105.0, 50.0, 2.0, 1.2),
         "B-V1": (100.0, 55.0, 1.2, 2.0), "B-V2": (110.0, 55.0, 1.2, 2.0)}


def new_model(schema: str = "IFC4", levels=(("Level 1", 0.0), ("Level 2", 3.5)),
              building_z_m: float | None = None):
    """A project, site, building and storeys "Level 1" (z 0) and "Level 2" (z 3.5);
    ``levels``: other storeys, (name, the world z of its placement, None: no placement);
    ``building_z_m``: the building placed at this height (the storeys' placements are
    written relative to it)."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.owner
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.unit

    api = ifcopenshell.api
    f = api.project.create_file(version=schema)
    if schema == "IFC2X3":  # owner history is mandatory there: the API takes the first user
        api.owner.add_application(f)
        person = api.owner.add_person(f, identification="T", family_name="Test", given_name="T")
        org = api.owner.add_organisation(f, identification="T", name="Test")
        api.owner.add_person_and_organisation(f, person=person, organisation=org)
    project = api.root.create_entity(f, ifc_class="IfcProject", name="Test")
    api.unit.assign_unit(f)  # millimetres: the footprints must come out in metres anyway
    model = api.context.add_context(f, context_type="Model")
    body = api.context.add_context(f, context_type="Model", context_identifier="Body",
                                   target_view="MODEL_VIEW", parent=model)
    site = api.root.create_entity(f, ifc_class="IfcSite", name="Site")
    building = api.root.create_entity(f, ifc_class="IfcBuilding", name="Building")
    api.aggregate.assign_object(f, products=[site], relating_object=project)
    api.aggregate.assign_object(f, products=[building], relating_object=site)
    if building_z_m is not None:
        matrix = np.eye(4)
        matrix[2, 3] = building_z_m
        api.geometry.edit_object_placement(f, product=building, matrix=matrix)
    storeys = {}
    for name, z in levels:
        storeys[name] = api.root.create_entity(f, ifc_class="IfcBuildingStorey", name=name)
        api.aggregate.assign_object(f, products=[storeys[name]], relating_object=building)
        if z is None:
            continue
        matrix = np.eye(4)
        matrix[2, 3] = z
        api.geometry.edit_object_placement(f, product=storeys[name], matrix=matrix)
    return f, body, storeys


def add_element(f, body, storey, ifc_class: str, name: str, polygon, z: float = 0.0,
                depth: float = 0.3):
    """An element whose body is ``polygon`` (plan, metres, world) extruded ``depth`` up."""
    import ifcopenshell.api.geometry
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial

    api = ifcopenshell.api
    element = api.root.create_entity(f, ifc_class=ifc_class, name=name)
    x0, y0 = polygon[0]
    local = [(x - x0, y - y0) for x, y in polygon]
    rep = api.geometry.add_slab_representation(f, context=body, depth=depth, polyline=local)
    api.geometry.assign_representation(f, product=element, representation=rep)
    matrix = np.eye(4)
    matrix[:3, 3] = (x0, y0, z)
    api.geometry.edit_object_placement(f, product=element, matrix=matrix)
    api.spatial.assign_container(f, products=[element], relating_structure=storey)
    return element


def box(x: float, y: float, w: float, h: float) -> list[tuple[float, float]]:
    return [(x - w / 2, y - h / 2), (x + w / 2, y - h / 2), (x + w / 2, y + h / 2),
            (x - w / 2, y + h / 2)]


def two_by_two(schema: str = "IFC4"):
    """The 2 x 2 slab storey with beams (module doc); returns (file, {name: element})."""
    f, body, storeys = new_model(schema)
    level = storeys["Level 1"]
    elements = {}
    for name, (x, y) in SLABS.items():
        elements[name] = add_element(f, body, level, "IfcSlab", name, box(x, y, 2.0, 2.0))
    for name, (x, y, w, h) in BEAMS.items():
        elements[name] = add_element(f, body, level, "IfcBeam", name, box(x, y, w, h),
                                     depth=0.5)
    add_element(f, body, level, "IfcWindow", "W-1", box(120.0, 55.0, 1.0, 0.2))
    return f, elements


def add_schedule(f, elements, tasks: dict[str, list[str]], sequences, kind="FINISH_START",
                 link="product"):
    """A work schedule with IfcTasks (name -> the elements each builds) and IfcRelSequence
    (relating task name, related task name); returns the tasks by name. IFC2X3: the entities
    are made by hand (the sequence API reads IfcTask.TaskTime, which IFC2X3 lacks). ``link``:
    "product", each task assigned to its elements (IfcRelAssignsToProduct), or "process", the
    elements assigned to the task (IfcRelAssignsToProcess)."""
    import ifcopenshell.api.owner
    import ifcopenshell.api.root
    import ifcopenshell.api.sequence
    import ifcopenshell.guid

    api = ifcopenshell.api
    old = f.schema == "IFC2X3"
    schedule = None if old else api.sequence.add_work_schedule(f, name="Plan")
    made = {}
    for k, (name, builds) in enumerate(tasks.items()):
        if old:
            made[name] = api.root.create_entity(f, ifc_class="IfcTask", name=name)
            made[name].TaskId, made[name].IsMilestone = f"T{k + 1}", False
        else:
            made[name] = api.sequence.add_task(f, work_schedule=schedule, name=name)
        for element in builds:
            if link == "product":
                api.sequence.assign_product(f, relating_product=elements[element],
                                            related_object=made[name])
            else:
                api.sequence.assign_process(f, relating_process=made[name],
                                            related_object=elements[element])
    for a, b in sequences:
        if old:
            f.create_entity("IfcRelSequence", GlobalId=ifcopenshell.guid.new(),
                            OwnerHistory=api.owner.create_owner_history(f),
                            RelatingProcess=made[a], RelatedProcess=made[b], TimeLag=0.0,
                            SequenceType=kind)
        else:
            api.sequence.assign_sequence(f, relating_process=made[a], related_process=made[b],
                                         sequence_type=kind)
    return made


def add_assembled(f, context, storey, ifc_class: str, name: str, polygon, z: float = 0.0,
                  depth: float = 0.3, part_class: str = "IfcBuildingElementProxy"):
    """An element with a placement at ``polygon``'s first corner, height ``z``, and no shape of
    its own; its body, ``polygon`` (plan, metres, world) extruded ``depth`` *down* from ``z``,
    on a ``part_class`` element aggregated to it (IfcRelAggregates). Returns (element, part)."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.geometry
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial

    api = ifcopenshell.api
    element = api.root.create_entity(f, ifc_class=ifc_class, name=name)
    x0, y0 = polygon[0]
    matrix = np.eye(4)
    matrix[:3, 3] = (x0, y0, z)
    api.geometry.edit_object_placement(f, product=element, matrix=matrix)
    api.spatial.assign_container(f, products=[element], relating_structure=storey)
    part = api.root.create_entity(f, ifc_class=part_class, name=f"{name} body")
    local = [(x - x0, y - y0) for x, y in polygon]
    rep = api.geometry.add_slab_representation(f, context=context, depth=depth, polyline=local)
    api.geometry.assign_representation(f, product=part, representation=rep)
    matrix = np.eye(4)
    matrix[:3, 3] = (x0, y0, z - depth)
    api.geometry.edit_object_placement(f, product=part, matrix=matrix)
    api.aggregate.assign_object(f, products=[part], relating_object=element)
    return element, part


def precast_deck(schema: str = "IFC4"):
    """The 3 x 3 deck of slabs on aggregated proxies (module doc); returns (file, {name:
    slab})."""
    import ifcopenshell.api.context

    f, _, storeys = new_model(schema)
    plan = ifcopenshell.api.context.add_context(f, context_type="Plan")
    return f, assembled_slabs(f, plan, storeys["Level 1"], DECK, DECK_SLAB_M, 0.25)


def assembled_slabs(f, context, storey, corners: dict, size: tuple[float, float],
                    depth: float) -> dict:
    """Slabs of ``size`` (metres) at ``corners`` (name -> lower left corner), each a
    placement whose body sits on an aggregated proxy (``add_assembled``): {name: slab}."""
    w, h = size
    return {name: add_assembled(f, context, storey, "IfcSlab", name,
                                box(x0 + w / 2, y0 + h / 2, w, h), z=0.0, depth=depth)[0]
            for name, (x0, y0) in corners.items()}


# the structural storey: (IFC class, name) -> (x0, y0, x1, y1, z bottom, depth), metres
BEARING = {
    **{("IfcSlab", f"S-{k + 1}"): (x0, y0, x0 + 6.0, y0 + 3.0, 0.0, 0.3)
       for k, (x0, y0) in enumerate(((0.0, 0.0), (6.0, 0.0), (0.0, 3.0), (6.0, 3.0)))},
    **{("IfcBeam", f"B-{k + 1}"): (x - 0.2, 0.0, x + 0.2, 6.0, -0.6, 0.6)
       for k, x in enumerate((0.0, 6.0, 12.0))},
    ("IfcBeam", "B-X"): (0.0, 2.8, 12.0, 3.2, -0.6, 0.6),
    **{("IfcColumn", f"C-{k + 1}"): (x - 0.2, y - 0.2, x + 0.2, y + 0.2, -3.5, 3.5)
       for k, (x, y) in enumerate(((0, 0), (6, 0), (12, 0), (0, 6), (6, 6), (12, 6)))},
    ("IfcWall", "W-BELOW"): (0.0, -0.1, 12.0, 0.1, -3.0, 3.0),
    ("IfcWall", "W-1"): (15.0, 0.0, 15.3, 6.0, 0.0, 3.0),
}


def slabs_on_beams(schema: str = "IFC4"):
    """The structural storey (module doc); returns (file, {name: element})."""
    return storey_of_boxes(BEARING, schema)


def storey_of_boxes(elements: dict, schema: str, **levels):
    """A model whose "Level 1" holds ``elements``: (IFC class, name) -> (x0, y0, x1, y1,
    z bottom, depth), metres; returns (file, {name: element}). ``levels``: new_model's."""
    f, body, storeys = new_model(schema, **levels)
    made = {}
    for (ifc_class, name), (x0, y0, x1, y1, z, depth) in elements.items():
        made[name] = add_element(f, body, storeys["Level 1"], ifc_class, name,
                                 box((x0 + x1) / 2, (y0 + y1) / 2, x1 - x0, y1 - y0), z=z,
                                 depth=depth)
    return f, made


# the wide-slab deck: slab "W-rc" -> its lower left corner (metres)
WIDE_SLAB_M = (4.0, 2.4)
WIDE_JOINTS_M = (0.0, 0.02, 0.04, 0.06, 0.08)  # between the slabs of rows 1..5
WIDE_ROW_JOINT_M = 0.05
WIDE = {f"W-{r + 1}{c + 1}": (300.0 + c * (WIDE_SLAB_M[0] + joint),
                              200.0 + r * (WIDE_SLAB_M[1] + WIDE_ROW_JOINT_M))
        for r, joint in enumerate(WIDE_JOINTS_M) for c in range(5)}


def wide_slab_deck(schema: str = "IFC4"):
    """The 5 x 5 wide-slab deck (module doc); returns (file, {name: slab})."""
    f, body, storeys = new_model(schema)
    return f, assembled_slabs(f, body, storeys["Level 1"], WIDE, WIDE_SLAB_M, 0.07)


# the L: (IFC class, name) -> (x0, y0, x1, y1, z bottom, depth), metres
HOLLOW_CORE_JOINT_M = 0.02
L_STOREY = {
    **{("IfcSlab", f"H-{k + 1}"): (x0, 0.0, x0 + 1.2, 6.0, 0.0, 0.2)
       for k, x0 in enumerate(1.22 * n for n in range(8))},
    **{("IfcSlab", f"H-{k + 9}"): (x0, 6.02, x0 + 1.2, 12.02, 0.0, 0.2)
       for k, x0 in enumerate(1.22 * n for n in range(4))},
    ("IfcBeam", "B-1"): (0.0, -0.2, 9.74, 0.2, -0.5, 0.5),
    ("IfcBeam", "B-2"): (0.0, 5.81, 9.74, 6.21, -0.5, 0.5),
    ("IfcBeam", "B-3"): (0.0, 11.82, 4.86, 12.22, -0.5, 0.5),
    **{("IfcColumn", f"C-{k + 1}"): (x - 0.2, y - 0.2, x + 0.2, y + 0.2, -3.0, 3.0)
       for k, (x, y) in enumerate(((0.0, 0.0), (9.74, 0.0), (9.74, 6.01), (4.86, 6.01),
                                   (4.86, 12.02), (0.0, 12.02)))},
}


def l_storey(schema: str = "IFC4"):
    """The L-shaped storey of hollow-core slabs (module doc); returns (file, {name:
    element})."""
    return storey_of_boxes(L_STOREY, schema)


# the structural storey 3 m up: BEARING's elements raised by 3 m (slabs z 3..3.3)
BEARING_UP = {key: (x0, y0, x1, y1, z + 3.0, depth)
              for key, (x0, y0, x1, y1, z, depth) in BEARING.items()}


def raised_storey(schema: str = "IFC4", elevation_m: float | None = None,
                  placement_m: float | None = None, building_z_m: float | None = None):
    """``BEARING_UP``: four slabs on the level, z 3..3.3, on crossing beams (z 2.4..3) and
    columns (z -0.5..3) and a wall of the storey below (z 0..3), a wall standing on the floor
    (z 3..6), all on "Level 1", the building's only storey, with its level stated as asked:
    its ``Elevation`` (written in the model's millimetres), its placement's world z
    (relative to the building's at ``building_z_m``), or neither (the storey the issue names:
    an IFC4 storey with neither an Elevation nor a placement). Returns (file, {name:
    element})."""
    f, made = storey_of_boxes(BEARING_UP, schema, levels=(("Level 1", placement_m),),
                              building_z_m=building_z_m)
    if elevation_m is not None:
        f.by_type("IfcBuildingStorey")[0].Elevation = elevation_m * 1000.0
    return f, made


# the notched wide-slab deck: WIDE with five slabs drawn as polygons (corners from the slab's
# lower left corner, metres) and a filler piece in W-11's notch, 50 mm off its edges
NOTCH_M = (1.0, 0.8)  # a corner cut out, along x and along y
SLANT_M = 0.6  # a trapezoid's slanted side leans in this much


def _notched(w: float, h: float) -> list[tuple[float, float]]:
    nx, ny = NOTCH_M
    return [(0, 0), (w, 0), (w, h - ny), (w - nx, h - ny), (w - nx, h), (0, h)]


def _trapezoid(w: float, h: float) -> list[tuple[float, float]]:
    return [(0, 0), (w, 0), (w - SLANT_M, h), (0, h)]


NOTCHED_SHAPES = {"W-11": _notched, "W-55": _notched, "W-13": _trapezoid, "W-31": _trapezoid,
                  "W-35": _trapezoid}


def notched_wide_slab_deck(schema: str = "IFC4"):
    """``wide_slab_deck``'s 25 slabs (millimetres, bodies on aggregated proxies), W-11 and
    W-55 notched (a 1.0 x 0.8 m corner cut at their top right: they fill 92 % of their box),
    W-13, W-31 and W-35 trapezoidal (the right side leaning in 0.6 m: 94 %), and "W-F", a
    0.9 x 0.7 m filler slab in W-11's notch 50 mm off its edges: inside W-11's box, clear of
    W-11. Returns (file, {name: slab})."""
    f, body, storeys = new_model(schema)
    w, h = WIDE_SLAB_M
    made = {}
    for name, (x0, y0) in WIDE.items():
        local = NOTCHED_SHAPES.get(name, lambda w, h: [(0, 0), (w, 0), (w, h), (0, h)])(w, h)
        made[name] = add_assembled(f, body, storeys["Level 1"], "IfcSlab", name,
                                   [(x0 + x, y0 + y) for x, y in local], z=0.0, depth=0.07)[0]
    x0, y0 = WIDE["W-11"]
    fx0, fy0 = x0 + w - NOTCH_M[0] + 0.05, y0 + h - NOTCH_M[1] + 0.05
    made["W-F"] = add_assembled(f, body, storeys["Level 1"], "IfcSlab", "W-F",
                                box(fx0 + 0.45, fy0 + 0.35, 0.9, 0.7), z=0.0, depth=0.07)[0]
    return f, made


# the edge-beam storey (issue 41, reach rule (a)): (IFC class, name) -> (x0, y0, x1, y1,
# z bottom, depth), metres; slabs 4 x 3 m, two rows 4 m apart, the model at x 400..413,
# y 299.6..310 (the slabs' x in halves of a metre: exact in binary, so the joints touch the
# slabs exactly after centring)
EDGE_X0 = [400.0 + k * 4.5 for k in range(3)]  # the slabs' left edges: 0.5 m joints
EDGE_STOREY = {
    **{("IfcSlab", f"S-{k + 1}"): (x0, 300.0, x0 + 4.0, 303.0, 0.0, 0.25)
       for k, x0 in enumerate(EDGE_X0)},  # the bottom row, joints J-1, J-2 between them
    **{("IfcSlab", f"S-{k + 4}"): (x0, 307.0, x0 + 4.0, 310.0, 0.0, 0.25)
       for k, x0 in enumerate(EDGE_X0)},  # the top row, 0.5 m apart, beyond a 4 m lane
    **{("IfcBeam", f"J-{k + 1}"): (x0 + 4.0, 300.0, x0 + 4.5, 303.0, 0.0, 0.4)
       for k, x0 in enumerate(EDGE_X0[:2])},
    # the edge beam along the bottom row's outer edge, on the floor (a component)
    ("IfcBeam", "B-E1"): (400.0, 299.6, 413.0, 300.0, 0.0, 0.4),
}
# the variant: a second edge beam along the bottom row's inner edge, the one facing the lane
EDGE_CLOSING_BEAM = {("IfcBeam", "B-E2"): (400.0, 303.0, 413.0, 303.4, 0.0, 0.4)}


def edge_beam_storey(schema: str = "IFC2X3", closed: bool = False):
    """Issue 41's storey for the reach rule: IFC2X3 (placements, no Elevation), 24 tasks with
    the default recipe. Bottom row: slabs S-1, S-2, S-3 (4 x 3 m, z 0..0.25) with 0.5 m
    cast-in-place joints J-1, J-2 between them and B-E1, a 0.4 m beam on the floor (z 0..0.4)
    along the row's outer edge, 13 m, from S-1's outer corner to S-3's; top row: S-4, S-5,
    S-6, 4 m above across a lane, 0.5 m apart. S-2's JC area (1.2 m round it) holds no point
    where a JCC (1.13 m radius, 1.03 m off components) fits along B-E1 (0.8 m beyond it) nor
    beside the joints (0.5 m to the next slab), but does along the lane. ``closed``: B-E2, a
    second 0.4 m beam along the row's lane edge, 13 m, closes that edge off too: no JCC can
    stand in S-2's JC area anywhere. Returns (file, {name: element})."""
    return storey_of_boxes({**EDGE_STOREY, **(EDGE_CLOSING_BEAM if closed else {})}, schema)
