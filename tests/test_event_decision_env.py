"""The stage-2 decision env on the event floor (issue 30, item 6): its Gymnasium id, its spaces
equal to the pymunk env's (a model trained on one runs on the other), seeding, and that it
drives the floor through the same engine calls with no low level."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import cmdp_pymunk
from cmdp_pymunk.adapters.decision_loop import DecisionLoop, TargetEvaluationEnv
from cmdp_pymunk.adapters.registry import DECISION_VARIANTS
from cmdp_pymunk.eventfloor import EventFloor, calibration_for, load_calibration, uncalibrated
from cmdp_pymunk.eventfloor.calibration import CrewTypeCalibration, write_calibration

PYMUNK_ID, EVENT_ID = "cmdp/TargetEvaluation-v1", "cmdp/TargetEvaluationEvent-v1"
SHORT_S = 3000.0  # the built-in floor cut here: a few decisions, under a second on pymunk


def trajectory(env, seed: int, actions_seed: int = 0, limit: int = 10_000) -> list:
    """Every step's (observation, reward, terminated, truncated) of one episode on ``seed``,
    the actions drawn uniformly from a generator seeded ``actions_seed``, then the end info."""
    rng = np.random.default_rng(actions_seed)
    obs, _ = env.reset(seed=seed)
    steps = [(obs, 0.0, False, False)]
    for _ in range(limit):
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        assert env.observation_space.contains(obs)
        steps.append((obs, reward, terminated, truncated))
        if terminated or truncated:
            return steps + [info]
    raise AssertionError(f"no episode end after {limit} decisions")


def same(a: list, b: list) -> bool:
    return len(a) == len(b) and all(
        np.array_equal(x[0], y[0]) and x[1:] == y[1:] for x, y in zip(a[:-1], b[:-1], strict=True)
    ) and a[-1] == b[-1]


def test_both_ids_are_in_gymnasiums_registry():
    assert set(DECISION_VARIANTS) == {PYMUNK_ID, EVENT_ID}
    for env_id in DECISION_VARIANTS:
        assert env_id in gymnasium.registry
    env = gymnasium.make(EVENT_ID, case=cmdp_pymunk.TINY_CASE)
    assert isinstance(env.unwrapped, TargetEvaluationEnv)
    floor = env.unwrapped.floor
    assert isinstance(floor.engine, EventFloor) and floor.fidelity == "event"
    assert floor.low_level is None and not floor.engine.motion.takes_actions
    assert floor.engine.evaluator is None  # values come from the env's actions
    pymunk = gymnasium.make(PYMUNK_ID, case=cmdp_pymunk.TINY_CASE).unwrapped.floor
    assert pymunk.fidelity == "pymunk" and pymunk.engine.motion.takes_actions
    assert type(pymunk.low_level).__name__ == "Navigator"  # the default low level


@pytest.mark.parametrize("case", [None, cmdp_pymunk.TINY_CASE], ids=["builtin", "tiny"])
@pytest.mark.parametrize("with_state", [False, True])
def test_spaces_equal_the_pymunk_envs(case, with_state):
    kwargs = {"with_state": with_state} | ({"case": case} if case else {})
    event = gymnasium.make(EVENT_ID, **kwargs)
    pymunk = gymnasium.make(PYMUNK_ID, **kwargs)
    assert event.observation_space == pymunk.observation_space
    assert event.action_space == pymunk.action_space
    assert event.observation_space.dtype == np.float32 and event.action_space.shape == (2,)


def test_resets_with_a_seed_and_steps_to_the_end_on_the_tiny_case():
    env = gymnasium.make(EVENT_ID, case=cmdp_pymunk.TINY_CASE)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs) and info == {}
    steps = trajectory(env, seed=0)
    end = steps[-1]
    assert steps[-2][2] and not steps[-2][3]  # terminated: every task ended
    assert end["makespan_s"] == end["time_s"] > 0 and not end["stalled"]
    assert end["tasks_ended"] == len(env.unwrapped.floor.engine.site.tasks)
    assert np.all(steps[-2][0] == 0)  # the last observation is zeros, as on the pymunk env


@pytest.mark.parametrize("kwargs", [{"case": cmdp_pymunk.TINY_CASE}, {"max_time_s": SHORT_S}],
                         ids=["tiny", "builtin-cut"])
def test_the_same_seed_twice_gives_the_same_trajectory(kwargs):
    a, b = gymnasium.make(EVENT_ID, **kwargs), gymnasium.make(EVENT_ID, **kwargs)
    first = trajectory(a, seed=3)
    assert len(first) > 2
    assert same(first, trajectory(b, seed=3))  # another env
    assert same(first, trajectory(a, seed=3))  # the same env after another episode
    log = a.unwrapped.floor.engine.log.events
    trajectory(b, seed=3)
    assert log == b.unwrapped.floor.engine.log.events


@pytest.mark.parametrize("kwargs", [{"case": cmdp_pymunk.TINY_CASE}, {"max_time_s": SHORT_S}],
                         ids=["tiny", "builtin-cut"])
def test_one_action_sequence_runs_to_the_end_on_both_floors(kwargs):
    """Model-free: what a policy trained on one floor feeds the other (same spaces, the same
    actions) runs to the episode's end on both without error."""
    for env_id in (PYMUNK_ID, EVENT_ID):
        steps = trajectory(gymnasium.make(env_id, **kwargs), seed=1, actions_seed=7)
        assert steps[-2][2] or steps[-2][3]


@pytest.mark.slow
def test_one_action_sequence_runs_whole_builtin_episodes_on_both_floors():
    for env_id in (PYMUNK_ID, EVENT_ID):
        env = gymnasium.make(env_id)
        for seed in (0, 1):
            steps = trajectory(env, seed=seed, actions_seed=seed)
            assert steps[-2][2] and steps[-1]["makespan_s"] is not None


def test_a_bad_fidelity_names_the_choices():
    with pytest.raises(ValueError, match="'physics' is not one of pymunk, event"):
        gymnasium.make(EVENT_ID, case=cmdp_pymunk.TINY_CASE, fidelity="physics")
    with pytest.raises(ValueError, match="pymunk, event"):
        DecisionLoop(cmdp_pymunk.TINY_CASE, fidelity="Event")


def test_passes_gymnasiums_env_checker():
    check_env(gymnasium.make(EVENT_ID, case=cmdp_pymunk.TINY_CASE).unwrapped,
              skip_render_check=True)


def test_no_low_level_is_made_on_the_event_floor_and_rewards_add_up():
    """The loop talks to the event floor through the same engine calls (advance, pending,
    set_target_values) and never makes a low level; R_e of every decision plus the part before
    the first one is the episode's R_e (Eq. 5, the team's)."""

    def no_low_level():
        raise AssertionError("the event floor has no low level")

    floor = DecisionLoop(None, no_low_level, fidelity="event", max_time_s=SHORT_S)
    total = floor.reset(seed=2)
    rng = np.random.default_rng(0)
    while True:
        assert floor.deciding == floor.engine.pending[0]
        assert len(floor.engine.site.crews[floor.deciding].scope) > 1
        out = floor.decide(rng.uniform(-1.0, 1.0, 2))
        total += out.reward
        if out.terminated or out.truncated:
            break
    assert out.truncated and floor.engine.site.time_s == SHORT_S
    assert total == pytest.approx(sum(floor.end_info()["episode_terms"].values()))


def test_the_calibration_is_the_cases_unless_given(tmp_path):
    case = cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    floor = DecisionLoop(cmdp_pymunk.TINY_CASE, fidelity="event")
    assert floor.engine.motion.calibration == calibration_for(case, cmdp_pymunk.TINY_CASE)
    fitted = uncalibrated(case).model_copy(update={
        "fitted_on": "a test", "crew_types": {t: CrewTypeCalibration(walk_factor=2.0)
                                              for t in case.crew_types}})
    path = write_calibration(fitted, tmp_path / "tiny.event.toml")
    assert load_calibration(path, case) == fitted
    for given in (fitted, path, str(path)):
        env = gymnasium.make(EVENT_ID, case=cmdp_pymunk.TINY_CASE, calibration=given)
        assert env.unwrapped.floor.engine.motion.calibration == fitted
