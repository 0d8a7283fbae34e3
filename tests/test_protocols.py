"""One protocol per role (docs/architecture.md): an evaluator and a low level written from the
doc's recipes run everywhere the built-in ones do, with no other change; the engine branches
alone; the core imports without PettingZoo."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from agents.lookahead import LookaheadEvaluator, LookaheadSettings
from agents.navigator import Navigator
from agents.steering import steer
from cmdp_pymunk import TINY_CASE, CMDPEnv, load_case
from cmdp_pymunk.adapters.decision_loop import DecisionLoop
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import Evaluator, TargetEvaluator
from cmdp_pymunk.policy import LowLevel
from cmdp_pymunk.rollout import play, run_episode
from training.runs.runner import EpisodeRunner


class FarthestFirst(Evaluator):
    """The recipe's evaluator: V_Tar from the engine, crew i's farthest target worth most."""

    def values_for(self, engine, i):
        x, y = engine.positions[i]
        site = engine.site
        d = {t: math.dist((x, y), site.target_xy[t]) for t in site.crews[i].scope}
        far = max(d.values(), default=0.0) or 1.0
        return {t: 0.5 + 0.5 * v / far for t, v in d.items()}


class CountingSteering:
    """The recipe's low level: greedy steering, counting its calls per episode in
    ``engine.memory`` (so a branch of the floor counts on from the original's count)."""

    reads_rays = False

    def bind(self, engine):
        pass

    def reset(self, seed):
        pass

    def actions(self, engine, observations=None):
        engine.memory["counting"] = engine.memory.get("counting", 0) + 1
        return [steer(engine, i) for i in range(len(engine.site.crews))]


def test_the_recipes_meet_the_protocols():
    assert isinstance(FarthestFirst(), TargetEvaluator)
    assert isinstance(CountingSteering(), LowLevel)
    assert isinstance(Navigator(), LowLevel)


def test_a_recipe_evaluator_runs_in_the_episode_library_and_the_lookahead():
    case = load_case(TINY_CASE)
    # what cmdp-evaluate and the GA run (an evaluator object on the runner's engine)
    row = EpisodeRunner(case).run(FarthestFirst(), "scripted", 0)
    assert row["finished"] and row["makespan_s"] > 0
    # what cmdp-simulate runs
    episode = run_episode(Engine(case, evaluator=FarthestFirst(), park_idle=True), Navigator(),
                          0, stall_s=3600.0, progress=False)
    assert episode.makespan_s == row["makespan_s"]
    # the lookahead's base rule
    lookahead = LookaheadEvaluator(FarthestFirst(), LookaheadSettings(candidates=2, futures=0))
    engine = Engine(case, evaluator=lookahead, park_idle=True)
    assert run_episode(engine, Navigator(), 0, stall_s=3600.0, progress=False).makespan_s
    assert lookahead.decisions


def test_a_recipe_low_level_runs_in_stage_1_stage_2_and_the_lookahead():
    case = load_case(TINY_CASE)
    low = CountingSteering()
    env = CMDPEnv(case, stage=1, max_time_s=300.0)  # stage 1, through the PettingZoo adapter
    observations, _ = env.reset(seed=0)
    while env.agents:
        observations, *_ = env.step(env.agent_actions(low, observations))
    assert env.engine.memory["counting"] > 0
    floor = DecisionLoop(None, CountingSteering, max_time_s=600.0)  # stage 2's loop, built-in floor
    floor.reset(seed=0)
    floor.decide((0.0, 0.0))
    assert floor.engine.memory["counting"] > 0
    lookahead = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=0),
                                   low_level=CountingSteering())
    engine = Engine(case, evaluator=lookahead, max_time_s=900.0)
    run_episode(engine, low, 0, stall_s=None, progress=False)
    assert lookahead.decisions and engine.memory["counting"] > 0


def test_a_clone_alone_continues_to_the_same_schedule():
    case = load_case(TINY_CASE)
    engine = Engine(case, evaluator="priority", park_idle=True)
    navigator = Navigator()
    engine.reset(seed=3)
    while engine.site.time_s < 200.0:
        engine.advance(navigator.actions(engine), until=engine.decision_due)
    branch = engine.clone()
    assert branch.memory["navigator"] is not engine.memory["navigator"]
    assert branch.memory["navigator"].engine is branch  # its plans moved with it
    play(engine, navigator)
    play(branch, navigator)
    assert engine.makespan_s is not None
    assert branch.log.events == engine.log.events


@pytest.mark.parametrize("blocked", ["pettingzoo", "gymnasium"])
def test_the_core_imports_without_the_rl_libraries(blocked):
    code = (f"import sys; sys.modules[{blocked!r}] = None\n"
            "import cmdp_pymunk.engine, cmdp_pymunk.cases.load, cmdp_pymunk.state, "
            "cmdp_pymunk.decide, cmdp_pymunk.rollout, cmdp_pymunk.evaluate\n"
            "from cmdp_pymunk import load_case, TINY_CASE\n"
            "from cmdp_pymunk.engine import Engine\n"
            "e = Engine(load_case(TINY_CASE), evaluator='priority'); e.reset(0)\n"
            "print(len(e.site.crews))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "2"  # the tiny case's crews


def test_importing_the_package_registers_the_variants():
    import pettingzoo

    import cmdp_pymunk

    env = pettingzoo.make("parallel", "cmdp/TinyFloor-v1")
    assert isinstance(env, cmdp_pymunk.CMDPEnv)
    assert callable(cmdp_pymunk.env)  # the AEC maker, not the adapter module


def test_reset_creates_no_attribute_that_init_does_not_declare():
    case = load_case(TINY_CASE)
    fresh = Engine(case, evaluator="priority")
    declared = set(vars(fresh))
    assert fresh.positions == [] and fresh.memory == {} and fresh.site is None
    fresh.reset(seed=0)
    assert set(vars(fresh)) == declared
    fresh.advance([(0, 1, 1)] * len(case.crews))
    assert set(vars(fresh)) == declared


ROOMS = ("cmdp_pymunk", "agents", "training", "media", "benchmarks", "tools")


def named_in_the_architecture_doc() -> tuple[set[str], set[str]]:
    """The file paths (``dir/file.py``) and dotted names of the rooms that
    docs/architecture.md puts in backticks."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "architecture.md").read_text()
    text = re.sub(r"```.*?```", "", text, flags=re.S)  # the diagram: names, not code
    spans = re.findall(r"`([^`]+)`", text)
    paths = {m for s in spans for m in re.findall(r"\b[\w/]+\.py\b", s) if "/" in m}
    core = {p.stem for p in (root / "cmdp_pymunk").glob("*.py")}  # `evaluate.Rule` and such
    dotted = set()
    for span in spans:
        m = re.match(r"[a-z_]\w*(\.\w+)+", span)
        if m and m.group(0).split(".")[0] in ROOMS:
            dotted.add(m.group(0))
        elif m and m.group(0).split(".")[0] in core - {"engine", "env"} \
                and not span.endswith(".py"):  # `engine.site`: an instance, in prose
            dotted.add("cmdp_pymunk." + m.group(0))
    return paths, dotted


def test_every_module_and_name_in_the_architecture_doc_exists():
    import importlib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    paths, dotted = named_in_the_architecture_doc()
    assert len(paths) >= 5 and len(dotted) >= 10  # the doc names them; the test reads them
    missing = sorted(p for p in paths if not (root / p).exists())
    assert not missing, f"docs/architecture.md names files that do not exist: {missing}"
    unresolved = []
    for name in sorted(dotted):
        parts = name.split(".")
        for k in range(len(parts), 0, -1):  # the longest importable module, then attributes
            try:
                obj = importlib.import_module(".".join(parts[:k]))
            except ImportError:
                continue
            try:
                for attr in parts[k:]:
                    obj = getattr(obj, attr)
            except AttributeError:
                unresolved.append(name)
            break
        else:
            unresolved.append(name)
    assert not unresolved, f"docs/architecture.md names what the code lacks: {unresolved}"
