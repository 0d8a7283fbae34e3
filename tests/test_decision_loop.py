"""The stage-2 env on the engine: the floor alone, its Gymnasium adapter, reward attribution,
and that it adds nothing to the engine's dynamics."""

from pathlib import Path

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from test_layering import imported_modules

from agents.navigator import Navigator
from cmdp_pymunk import parallel_env
from cmdp_pymunk.adapters.decision_loop import DecisionLoop, TargetEvaluationEnv
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import (
    DesiredPositionEvaluator,
    PriorityEvaluator,
    desired_position_of_first_choice,
)

SHORT_S = 5000.0  # long enough for several decisions, short enough for a fast test
HIGHLEVEL = Path(__file__).resolve().parent.parent / "cmdp_pymunk" / "adapters" / "decision_loop.py"


def floor(**kwargs) -> DecisionLoop:
    return DecisionLoop(None, Navigator, max_time_s=SHORT_S, **kwargs)


def schedule(log, values: bool = True):
    """The event log as tuples; ``values`` False leaves out the values reached (Eq. 4's and
    Eq. 9's values differ, their first choice does not)."""
    return [(e.time_s, e.kind, e.crew, e.subject) for e in log.events
            if values or e.kind != "reach"]


def play(fl: DecisionLoop, seed: int, choose) -> list:
    """Every decision's (crew, reward, terminated, truncated) of one episode on ``seed``."""
    fl.reset(seed)
    return play_on(fl, choose)


def play_on(fl: DecisionLoop, choose) -> list:
    """``play`` from the floor's current decision on."""
    trace = []
    while True:
        crew = fl.deciding
        out = fl.decide(choose(fl))
        trace.append((crew, out.reward, out.terminated, out.truncated))
        if out.terminated or out.truncated:
            return trace


def test_the_floor_steps_the_engine_alone():
    """No PettingZoo env under the stage-2 env: the floor holds an engine and asks only for
    decisions among several targets, by crew index."""
    names = imported_modules(HIGHLEVEL)
    assert "cmdp_pymunk.adapters.env" not in names and "pettingzoo" not in {n.split(".")[0]
                                                                     for n in names}
    fl = floor()
    assert isinstance(fl.engine, Engine) and fl.engine.evaluator is None
    fl.reset(seed=2)
    for _ in range(5):
        i = fl.deciding
        assert i == fl.engine.pending[0] and len(fl.engine.site.crews[i].scope) > 1
        obs = fl.observe()
        assert obs.shape == fl.low.shape and np.all((obs >= fl.low) & (obs <= fl.high))
        out = fl.decide((0.0, 0.0))
        assert not (out.terminated or out.truncated) and fl.deciding is not None


def test_passes_gymnasium_env_checker():
    check_env(TargetEvaluationEnv(floor()), skip_render_check=True)


def test_the_floor_adds_nothing_to_the_engine():
    """Eq. 4 at the heuristic's first choice, through the floor's decisions (training) and
    through an evaluator injected into the engine (deployment, as ``ModelEvaluator``): the
    same event log, values reached included."""

    class FirstChoice(DesiredPositionEvaluator):
        def desired_position(self, crew, site, position):
            return desired_position_of_first_choice(crew, site, position)

    engine = Engine(floor().case, stage=2, evaluator=FirstChoice(), max_time_s=SHORT_S)
    navigator = Navigator()
    engine.reset(seed=4)
    while True:
        run = engine.advance(navigator.actions(engine), until=engine.decision_due)
        if run.terminated or run.truncated:
            break

    fl = floor()
    decisions = play(fl, 4, lambda f: f.teacher_action())
    assert len(decisions) > 4
    assert schedule(fl.engine.log) == schedule(engine.log)


def test_external_values_with_the_heuristic_reproduce_its_schedule():
    """Feeding Eq. 9's choice through Eq. 4 gives the PettingZoo env's heuristic schedule."""
    reference = parallel_env(seed=3, evaluator=PriorityEvaluator(), max_time_s=SHORT_S)
    navigator = Navigator()
    obs, _ = reference.reset(seed=3)
    while reference.agents:
        obs, *_ = reference.step(reference.agent_actions(navigator, obs))

    fl = floor()
    play(fl, 3, lambda f: f.teacher_action())
    assert schedule(fl.engine.log, values=False) == schedule(reference.log, values=False)


def test_a_value_for_a_crew_that_was_not_asked_is_refused():
    fl = floor()
    fl.reset(seed=0)
    engine = fl.engine
    other = next(c for c in engine.site.crews if c.index not in engine.pending)
    before = dict(other.values)
    with pytest.raises(ValueError, match=rf"crew {other.index} \({other.id}\) was not asked "
                                         r"for target values; the engine asks for crews: "
                                         rf"{fl.deciding} \("):
        engine.set_target_values(other.index, {t: 0.7 for t in other.scope})
    assert other.values == before
    with pytest.raises(ValueError, match="one value per target in scope"):
        engine.set_target_values(fl.deciding, {})  # the engine's own check


def test_a_finished_floor_asks_for_a_reset():
    fl = DecisionLoop(None, Navigator, max_time_s=600.0)
    fl.reset(seed=0)
    while not (out := fl.decide((0.0, 0.0))).truncated:
        assert not out.terminated
    with pytest.raises(RuntimeError, match=r"no crew deciding.*reset\(seed\)"):
        fl.decide((0.0, 0.0))


def test_rewards_credit_every_second_after_the_first_decision_once():
    """The decisions' rewards add up to R_e summed over every simulated second from the
    first decision to the end, as the engine reports it: nothing lost or counted twice."""
    fl = floor()
    reported = []
    advance = fl.engine.advance

    def recording_advance(actions, until=None):
        run = advance(actions, until)
        reported.append(sum(run.terms.values()))
        return run

    fl.engine.advance = recording_advance
    before = fl.reset(seed=1)
    assert before == pytest.approx(sum(reported))  # credited to no decision
    reported.clear()
    rng = np.random.default_rng(0)
    trace = play_on(fl, lambda _: rng.uniform(-1, 1, 2))
    assert fl.engine.site.time_s == SHORT_S and trace[-1][3]  # cut at the time limit
    assert len(reported) > 100
    assert sum(r for _, r, *_ in trace) == pytest.approx(sum(reported))
    assert sum(fl.end_info()["episode_terms"].values()) == pytest.approx(
        before + sum(reported))


def test_same_seed_same_decisions():
    def run():
        env = TargetEvaluationEnv(floor(with_state=True))
        obs, _ = env.reset(seed=5)
        trace = [obs.tobytes()]
        rng = np.random.default_rng(1)
        while True:
            obs, r, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2))
            trace.append((obs.tobytes(), r))
            if terminated or truncated:
                return trace
    assert run() == run()


def test_the_crew_values_highest_the_target_nearest_the_desired_position():
    fl = floor()
    given = []
    inner_set = fl.engine.set_target_values
    fl.engine.set_target_values = lambda i, values: (given.append(dict(values)),
                                                     inner_set(i, values))
    fl.reset(seed=0)
    site = fl.engine.site
    crew = site.crews[fl.deciding]
    half_w, half_h = site.case.plane.half_extents
    east = max(crew.scope, key=lambda t: site.target_xy[t][0])
    x, y = site.target_xy[east]
    given.clear()
    fl.decide(np.array([x / half_w, y / half_h]))
    values = given[0]
    assert max(values, key=values.get) == east and values[east] == 1.0
    assert min(values.values()) == 0.5  # as_target_values: the scope spread over [0.5, 1]


def test_a_stalled_floor_is_cut_by_the_engine_guard_and_says_so():
    """One stall guard, the engine's: a floor whose crews never move (the low level stands
    them still) is truncated after ``stall_s`` without progress, and the end info says so."""

    class StandStill(Navigator):
        def actions(self, engine, observations=None):
            return [(0, 1, 1)] * len(engine.site.crews)

    fl = DecisionLoop(None, StandStill, stall_s=600.0)
    fl.reset(seed=0)
    while not (out := fl.decide((0.0, 0.0))).truncated:
        assert not out.terminated
    info = fl.end_info()
    assert info["stalled"] and info["makespan_s"] is None
    assert fl.engine.stalled["after_s"] == pytest.approx(600.0)
    assert info["time_s"] < fl.engine.max_time_s
