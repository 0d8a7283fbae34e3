"""Who may import whom, read from the source with ``ast`` (every import, also those inside
functions): the core imports none of the packages built on it, and the two training stages
share code only through the scaffold."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def imported_modules(path: Path, tree: ast.AST | None = None) -> set[str]:
    """The absolute names of every module ``path`` imports (relative imports resolved); from
    ``tree`` if given (``path``'s, edited)."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    if tree is None:
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def first_parts(path: Path) -> set[str]:
    return {name.split(".")[0] for name in imported_modules(path)}


@pytest.mark.parametrize("path", sorted((ROOT / "cmdp_pymunk").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_the_core_imports_nothing_built_on_it(path):
    assert not first_parts(path) & {"agents", "training", "media", "benchmarks", "tools"}


def test_the_checker_sees_imports_inside_functions_and_relative_ones(tmp_path):
    sample = ROOT / "training" / "stage2.py"
    names = imported_modules(sample)
    assert "training.scaffold" in names  # ``from .scaffold import ...``
    assert "agents.central_critic" in names  # imported inside ``train``


@pytest.mark.parametrize("module, other", [("stage1", "stage2"), ("stage2", "stage1")])
def test_the_training_stages_do_not_import_each_other(module, other):
    names = imported_modules(ROOT / "training" / f"{module}.py")
    assert not {n for n in names if n == f"training.{other}" or
                n.startswith(f"training.{other}.")}, names
    assert "training.scaffold" in names
    # the command imports the stages, not the reverse
    assert not {n for n in names if n.startswith("training.commands")}, names


# -- the engine owns the floor: nothing built on the core reads its plane or an env's state ----

BUILT_ON_THE_CORE = ("agents", "training", "media", "tools", "benchmarks", "examples")
PLANE = {"world", "bodies"}  # the engine's plane (``physics.Physics``) and pymunk's bodies
ENV_STATE = {"site", "world", "positions"}  # read through ``env.engine``, never the env


def _dotted(node: ast.AST) -> str:
    """``self.env`` for the expression ``self.env`` (a name or a chain of attributes)."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
    return ".".join(reversed(parts))


def floor_state_reads(source: str) -> list[str]:
    """Where ``source`` reads what only the engine may: any ``.world`` or ``.bodies`` (the
    plane, pymunk's bodies), and ``.site``, ``.world`` or ``.positions`` of an env (a name
    ending in ``env``), as attributes or through ``getattr``/``hasattr``."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute):
            owner, name = _dotted(node.value), node.attr
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id in ("getattr", "hasattr", "setattr") and len(node.args) >= 2 \
                and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str):
            owner, name = _dotted(node.args[0]), node.args[1].value
        else:
            continue
        if owner == "cmdp_pymunk":  # a module's name (cmdp_pymunk.world), not a floor's state
            continue
        if name in PLANE or (name in ENV_STATE and owner.rsplit(".", 1)[-1].endswith("env")):
            out.append(f"line {node.lineno}: {owner or '<expression>'}.{name}")
    return out


def built_on_the_core() -> list[Path]:
    return [p for d in BUILT_ON_THE_CORE if (ROOT / d).is_dir()
            for p in sorted((ROOT / d).rglob("*.py"))]


@pytest.mark.parametrize("path", built_on_the_core(), ids=lambda p: str(p.relative_to(ROOT)))
def test_nothing_built_on_the_core_reads_the_plane_or_an_envs_state(path):
    reads = floor_state_reads(path.read_text(encoding="utf-8"))
    assert not reads, (f"{path.relative_to(ROOT)} reads the floor's state around its engine: "
                       f"{reads}; fix: read it through the engine (env.engine: site, "
                       "positions, pose(i), headings()), crews by index")
    assert "pymunk" not in first_parts(path), f"{path.relative_to(ROOT)} imports pymunk"


def test_the_floor_state_checker_sees_every_way_round():
    source = """
site = env.site
xy = self.env.positions[0]
angle = engine.world.bodies[0].angle
plane = getattr(tiny_env, "world", None)
fine = (engine.site, engine.positions, self.site, env.engine.site, cmdp_pymunk.world)
"""
    assert sorted(floor_state_reads(source)) == [
        "line 2: env.site", "line 3: self.env.positions", "line 4: engine.world",
        "line 4: engine.world.bodies", "line 5: tiny_env.world"]


def test_the_core_reaches_the_plane_only_through_the_physics_protocol():
    """Every member of a world read in the core (``world.X``, ``self.world.X``,
    ``ctx.world.X``) outside world.py is one of ``physics.Physics``'s, and only world.py (and
    ``report.versions``, for pymunk's version) imports pymunk. The event floor's own plane
    (``eventfloor.floor.EventPlane``) is driven by its floor alone: it is a Physics too."""
    from cmdp_pymunk.eventfloor.floor import EventPlane
    from cmdp_pymunk.physics import Physics

    members = {n for n in dir(Physics) if not n.startswith("_")} | set(Physics.__annotations__)
    assert members <= {n for n in dir(EventPlane)} | {"motion_version", "storage_rects"}
    used = {}
    for path in sorted((ROOT / "cmdp_pymunk").rglob("*.py")):
        if path.name in ("world.py", "physics.py") or path.parent.name == "eventfloor":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and _dotted(node.value).split(".")[-1] == "world":
                used.setdefault(node.attr, set()).add(path.name)
        if "pymunk" in first_parts(path):
            assert path.name == "report.py", f"{path.name} imports pymunk"
    assert {"pose", "step", "ray_query", "drive"} <= used.keys()  # the checker sees them
    assert not used.keys() - members, {k: used[k] for k in used.keys() - members}


def test_pymunks_world_is_a_physics():
    import cmdp_pymunk
    from cmdp_pymunk.physics import Physics
    from cmdp_pymunk.state import Site
    from cmdp_pymunk.world import World

    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    world = World(case, Site(case, 2))
    assert isinstance(world, Physics)
    x, y, heading = world.pose(0)
    assert (x, y) == (case.crews[0].start_x_m, case.crews[0].start_y_m)


# -- rooms (issue 29): which room may import which, and no circles -----------------------------

ROOM_RULES = {
    # room: rooms it must not import (anything not listed is allowed)
    "agents": {"training", "media", "benchmarks", "tools", "examples"},  # policies, evaluators
    "media": {"agents", "training", "benchmarks", "tools"},  # drawing from logs and engines
    # commands (issue 43): each a thin file over the libraries; none imports another
    "training/commands": {"training.commands", "training.research"},
    "training/runs": {"training.commands", "training.search",
                      "training.research"},  # machinery, no commands
    "training/search": {"training.commands", "training.research"},  # searches, not commands
    # the event floor's calibration and validation: machinery beside the event floor
    "training/eventfloor": {"training.commands", "training.search", "training.research"},
    # the event floor: the same stages without pymunk, rays or the adapters
    "cmdp_pymunk/eventfloor": {"cmdp_pymunk.world", "cmdp_pymunk.observe", "cmdp_pymunk.adapters",
                               "pymunk", "pettingzoo", "gymnasium"},
    # case input and output: the case as data, files, generators, IFC; no simulation stage
    "cmdp_pymunk/cases": {"cmdp_pymunk.engine", "cmdp_pymunk.world", "cmdp_pymunk.state",
                          "cmdp_pymunk.decide", "cmdp_pymunk.construct", "cmdp_pymunk.move",
                          "cmdp_pymunk.observe", "cmdp_pymunk.rollout", "cmdp_pymunk.report",
                          "cmdp_pymunk.adapters",
                          "pymunk", "pettingzoo", "gymnasium"},
}


# research wraps the policies from outside: no name in agents/ speaks of labelling them
RESEARCH_WORDS = ("distill", "label", "acting", "on_decision", "teacher", "relabel")


def test_agents_name_nothing_of_research():
    """Labels, teachers and acting policies live in ``training/research`` (``labelling``
    wraps the lookahead's public ``candidates_for`` / ``decide``): no identifier in
    ``agents/`` (names, attributes, arguments, definitions; not prose) names them."""
    bad = []
    for path in sorted((ROOT / "agents").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Name):
                names = [node.id]
            elif isinstance(node, ast.Attribute):
                names = [node.attr]
            elif isinstance(node, ast.arg):
                names = [node.arg]
            elif isinstance(node, (ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
                names = [node.name]
            for name in names:
                if any(w in name.lower() for w in RESEARCH_WORDS):
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {name}")
    assert not bad, f"agents/ names research: {bad}"


# the simulation core (cmdp_pymunk/*.py, not its rooms) imports no adapter
CORE_MODULES = sorted(p for p in (ROOT / "cmdp_pymunk").glob("*.py") if p.name != "__init__.py")


@pytest.mark.parametrize("path", CORE_MODULES, ids=lambda p: p.name)
def test_the_simulation_imports_no_adapter(path):
    names = imported_modules(path)
    assert not {n for n in names if n.startswith("cmdp_pymunk.adapters")
                or n.split(".")[0] in ("pettingzoo", "gymnasium")}, names


def _room_modules(room: str) -> list[Path]:
    return sorted((ROOT / room).rglob("*.py"))


@pytest.mark.parametrize("room", sorted(ROOM_RULES))
def test_each_room_imports_only_what_it_may(room):
    bad = []
    for path in _room_modules(room):
        for name in imported_modules(path):
            if any(name == f or name.startswith(f + ".") for f in ROOM_RULES[room]):
                bad.append(f"{path.relative_to(ROOT)} imports {name}")
    assert not bad, f"room {room}/ imports what it may not: {bad}"


def runtime_imports(path: Path) -> set[str]:
    """``imported_modules`` less the imports under ``if TYPE_CHECKING:`` (annotations only)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            node.body = [ast.Pass()]
    return imported_modules(path, tree)


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_no_module_of_the_project_imports_itself_round_a_circle():
    """Import circles, also through imports inside functions, among the project's modules."""
    paths = [p for room in ("cmdp_pymunk", "agents", "training", "media")
             for p in _room_modules(room)]
    names = {_module_name(p): p for p in paths}
    graph = {}
    for name, path in names.items():
        out = set()
        for imported in runtime_imports(path):
            while imported and imported not in names:  # ``pkg.mod.attr`` -> ``pkg.mod``
                imported = imported.rpartition(".")[0]
            if imported and imported != name and not name.startswith(imported + "."):
                out.add(imported)
        graph[name] = out
    circles, state = [], {}

    def visit(node, stack):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                circles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    # a package's __init__ that registers its own adapters is not a circle of rooms
    circles = [c for c in circles if not (c[0] == "cmdp_pymunk" or "cmdp_pymunk" in c)]
    assert not circles, " ; ".join(" -> ".join(c) for c in circles)


def test_no_two_modules_share_a_name():
    """One name per module across the rooms (tests, benchmarks, tools, examples aside): a reader
    who sees ``evaluate`` knows which one is meant."""
    seen: dict[str, list[str]] = {}
    for room in ("cmdp_pymunk", "agents", "training", "media"):
        for path in _room_modules(room):
            if path.name != "__init__.py":
                seen.setdefault(path.stem, []).append(str(path.relative_to(ROOT)))
    assert not {k: v for k, v in seen.items() if len(v) > 1}


def test_nothing_imports_a_command():
    """A command (``training/commands``) is the top of its chain: no module of the package,
    the benchmarks, the tools or the examples imports one (tests run them through ``main``);
    what two commands share is a library (``training.runs``, ``training.cli``, ...)."""
    bad = [f"{p.relative_to(ROOT)} imports {n}"
           for room in ("cmdp_pymunk", "agents", "training", "media", "benchmarks", "tools",
                        "examples")
           for p in _room_modules(room) if "commands" not in p.relative_to(ROOT).parts
           for n in imported_modules(p) if n.startswith("training.commands")]
    assert not bad, bad


def test_every_console_script_is_a_command():
    """``setup.cfg``'s console scripts all point into ``training/commands``, one module each."""
    import configparser

    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    targets = [line.split("=", 1)[1].strip() for line in
               cfg["options.entry_points"]["console_scripts"].strip().splitlines()]
    modules = [t.split(":")[0] for t in targets]
    assert modules and all(m.startswith("training.commands.") for m in modules), modules
    assert len(set(modules)) == len(modules), modules
    for module in modules:
        assert (ROOT / (module.replace(".", "/") + ".py")).is_file(), module


def test_nothing_imports_the_research_tools():
    """``training/research`` builds on the rest; nothing of the package depends on it."""
    bad = [f"{p.relative_to(ROOT)} imports {n}"
           for room in ("cmdp_pymunk", "agents", "training", "media")
           for p in _room_modules(room) if "research" not in p.parts
           for n in imported_modules(p) if n.startswith("training.research")]
    assert not bad, bad


def test_research_imports_at_its_module_tops():
    """Issue 43 item 3: research says what it builds on where a reader looks first, at the
    top of each module, not inside functions (where its imports once hid, 96 of them)."""
    bad = []
    for path in _room_modules("training/research"):
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for func in ast.walk(tree):
            if isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
                bad += [f"{path.relative_to(ROOT)}:{node.lineno} in {func.name}"
                        for node in ast.walk(func)
                        if isinstance(node, (ast.Import, ast.ImportFrom))]
    assert not bad, f"imports inside functions: {bad}; fix: move them to the module's top"
