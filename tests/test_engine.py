"""The engine alone, without PettingZoo: reset, one second, advance until, values from outside."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk import parallel_env
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import NearestFirstEvaluator
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.observe import ReachingObservations
from cmdp_pymunk.physics import Physics
from cmdp_pymunk.world import World


def test_the_engine_imports_no_rl_framework():
    # ``import cmdp_pymunk`` registers the PettingZoo variants, so the engine is loaded under a
    # bare package object: what it imports itself is all that ends up in sys.modules
    package = Path(cmdp_pymunk.__file__).parent
    code = (f"import sys, types; pkg = types.ModuleType('cmdp_pymunk'); "
            f"pkg.__path__ = [{str(package)!r}]; sys.modules['cmdp_pymunk'] = pkg; "
            "import cmdp_pymunk.engine; "
            "print(sorted(m for m in ('pettingzoo', 'gymnasium', 'stable_baselines3', 'torch', "
            "'pygame', 'media') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_one_second_and_advance_until(tiny_case):
    engine = Engine(tiny_case, stage=2, evaluator=NearestFirstEvaluator(), seed=0)
    engine.reset(seed=0)
    stand = [STAND_STILL] * len(tiny_case.crews)
    run = engine.advance(stand)  # no condition: one second
    assert (run.elapsed, engine.site.time_s, engine.steps) == (1, 1.0, 1)
    assert len(run.rewards) == len(tiny_case.crews)
    run = engine.advance(stand, until=lambda: engine.site.time_s >= 5.0)
    assert (run.elapsed, engine.site.time_s) == (4, 5.0)
    assert not run.terminated and not run.truncated


def test_bad_reaching_actions_are_refused_naming_what_was_expected(tiny_case):
    engine = Engine(tiny_case, evaluator=NearestFirstEvaluator())
    with pytest.raises(RuntimeError, match="reset"):
        engine.step([STAND_STILL] * len(tiny_case.crews))
    engine.reset(seed=0)
    n = len(tiny_case.crews)
    with pytest.raises(ValueError, match=f"1 reaching actions for {n} crews"):
        engine.step([STAND_STILL])
    moving = next(c for c in engine.site.crews if c.moving)
    for bad in [(4, 1, 1), (-1, 1, 1), (0, 1), (0, 1, 1, 0), "abc"]:
        actions = [STAND_STILL] * n
        actions[moving.index] = bad
        with pytest.raises(ValueError, match=rf"{moving.id} .*MultiDiscrete\(\[4, 3, 3\]\)"):
            engine.step(actions)
    actions = [STAND_STILL] * n
    actions[moving.index] = np.array([3, 2, 0])  # numpy's integers are whole numbers too
    engine.step(actions)


def test_the_time_limit_cuts_an_advance(tiny_case):
    engine = Engine(tiny_case, evaluator=NearestFirstEvaluator(), max_time_s=3.0)
    engine.reset(seed=0)
    run = engine.advance([STAND_STILL] * len(tiny_case.crews), until=lambda: False)
    assert (run.elapsed, run.truncated, run.terminated) == (3, True, False)


def test_without_an_evaluator_the_values_are_pending_until_given(tiny_case):
    engine = Engine(tiny_case, evaluator=None)
    engine.reset(seed=0)
    assert engine.pending, "crews with a new scope wait for values after reset"
    assert engine.decision_due()
    stand = [STAND_STILL] * len(tiny_case.crews)
    with pytest.raises(RuntimeError, match="set_target_values"):
        engine.advance(stand)
    i = engine.pending[0]
    crew = engine.site.crews[i]
    with pytest.raises(ValueError, match="one value per target"):
        engine.set_target_values(i, {})
    for i in list(engine.pending):
        engine.set_target_values(i, dict.fromkeys(engine.site.crews[i].scope, 1.0))
    assert not engine.pending and crew.values
    engine.advance(stand)


def test_the_adapter_runs_the_engines_schedule(tiny_case):
    """The PettingZoo env adds agents' names, spaces and infos, nothing to the dynamics."""
    env = parallel_env(case=tiny_case, seed=1, jump_idle=False, max_time_s=400,
                       evaluator="nearest")
    navigator = Navigator()
    obs, _ = env.reset(seed=1)
    actions_log = []
    while env.agents:
        actions = env.agent_actions(navigator, obs)
        actions_log.append([actions.get(a, STAND_STILL) for a in env.possible_agents])
        obs, *_ = env.step(actions)
    engine = Engine(tiny_case, evaluator=NearestFirstEvaluator(), max_time_s=400)
    engine.reset(seed=1)
    for actions in actions_log:
        engine.advance(actions)
    assert engine.log.events == env.log.events


class OnlyThePhysics:
    """pymunk's World seen only through ``physics.Physics``'s members: anything else the
    engine or its stages read of the plane raises."""

    MEMBERS = frozenset(n for n in dir(Physics) if not n.startswith("_")) \
        | frozenset(Physics.__annotations__)

    def __init__(self, case, site):
        self._world = World(case, site)

    def __getattr__(self, name):
        if name in OnlyThePhysics.MEMBERS:
            return getattr(self.__dict__["_world"], name)
        raise AttributeError(f"{name!r} is not a member of physics.Physics")


def test_a_plane_seen_only_through_the_protocol_plays_the_same_floor(tiny_case):
    def play(physics):
        engine = Engine(tiny_case, evaluator="priority", seed=0, physics=physics)
        engine.reset(seed=0)
        navigator = Navigator()
        navigator.reset(0)
        rays = ReachingObservations(tiny_case)
        seen = []
        while not engine.site.done:
            seen.append(np.concatenate(rays.all(engine)))
            engine.advance(navigator.actions(engine), until=engine.decision_due)
            if len(seen) == 10:
                engine.clone()  # a copy, and the original rebuilt (``rebuild``)
        return engine.log.events, seen

    assert not isinstance(OnlyThePhysics.__new__(OnlyThePhysics), World)
    events, seen = play(OnlyThePhysics)
    assert len(seen) > 20 and any(obs.any() for obs in seen)  # rays were cast
    assert any(e.kind == "crew_state" and e.subject == "left" for e in events)  # the outlet
    pymunk_events, pymunk_seen = play(World)
    assert events == pymunk_events
    assert all(np.array_equal(a, b) for a, b in zip(seen, pymunk_seen, strict=True))
