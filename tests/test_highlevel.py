"""The stage-2 high-level env: API, reward attribution, and the external-values seam."""

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from agents.navigator import Navigator
from cmdp_pymunk import parallel_env
from cmdp_pymunk.evaluate import PriorityEvaluator, desired_position_of_first_choice
from cmdp_pymunk.highlevel import TargetEvaluationEnv, decision_reward

SHORT_S = 5000.0  # long enough for several decisions, short enough for a fast test


def heuristic_action(hl: TargetEvaluationEnv) -> np.ndarray:
    """The desired position that makes Eq. 4 rank first the target Eq. 9 ranks first."""
    env = hl.env
    i = env.agent_index[hl.deciding_agent]
    return np.array(desired_position_of_first_choice(env.site.crews[i], env.site,
                                                     env.positions[i]), dtype=np.float32)


def test_decision_reward_sums_every_term_of_every_step():
    # two steps: (-0.01 - 0.02 + 0.005 - 0.001 - 0.003) + (0.01 - 0.001) = -0.029 + 0.009 = -0.02
    steps = [{"idle_pre": -0.01, "idle_area": -0.02, "efficiency": 0.005, "episode": -0.001,
              "path": -0.003},
             {"idle_pre": 0.0, "idle_area": 0.0, "efficiency": 0.01, "episode": -0.001,
              "path": 0.0}]
    assert decision_reward(steps) == pytest.approx(-0.02)
    assert decision_reward([]) == 0.0  # a second decision at the same second gets nothing


def test_passes_gymnasium_env_checker():
    hl = TargetEvaluationEnv(Navigator, max_time_s=SHORT_S)
    check_env(hl, skip_render_check=True)


def test_external_values_with_the_heuristic_reproduce_its_schedule():
    """Feeding Eq. 9's choice through Eq. 4 from outside gives the heuristic's own schedule."""
    reference = parallel_env(seed=3, evaluator=PriorityEvaluator(), max_time_s=SHORT_S)
    navigator = Navigator(reference)
    obs, _ = reference.reset(seed=3)
    while reference.agents:
        obs, *_ = reference.step(navigator.actions(reference, obs))

    hl = TargetEvaluationEnv(Navigator, max_time_s=SHORT_S)
    hl.reset(seed=3)
    decisions = 0
    while True:
        _, _, terminated, truncated, _ = hl.step(heuristic_action(hl))
        decisions += 1
        if terminated or truncated:
            break
    assert decisions > 4
    # the same schedule: every event but the reached value (Eq. 4's and Eq. 9's values differ,
    # their first choice does not)
    def schedule(log):
        return [(e.time_s, e.kind, e.crew, e.subject) for e in log.events]

    assert schedule(hl.env.log) == schedule(reference.log)


def test_rewards_credit_every_second_after_the_first_decision_once():
    """The decisions' rewards add up to R_e summed over every simulated second from the first
    decision to the end, as the inner env reports it: nothing lost or counted twice."""
    hl = TargetEvaluationEnv(Navigator, max_time_s=SHORT_S)
    reported = []
    inner_step = hl.env.step

    def recording_step(actions):
        out = inner_step(actions)
        reported.append(next(iter(out[4].values()))["evaluation_reward"])
        return out

    hl.env.step = recording_step
    hl.reset(seed=1)
    reported.clear()  # R_e before the first decision is credited to no decision
    total, rng = 0.0, np.random.default_rng(0)
    while True:
        _, r, terminated, truncated, info = hl.step(rng.uniform(-1, 1, 2))
        total += r
        if terminated or truncated:
            break
    assert info["time_s"] == SHORT_S
    assert len(reported) > 100
    assert total == pytest.approx(sum(reported))


def test_step_refuses_to_run_while_values_are_pending():
    env = parallel_env(seed=0, external_values=True, max_time_s=SHORT_S)
    env.reset(seed=0)
    assert env.pending_values  # every crew acquires its first scope at reset
    with pytest.raises(RuntimeError, match="set_target_values"):
        env.step({})
    agent = env.pending_values[0]
    crew = env.site.crews[env.agent_index[agent]]
    with pytest.raises(ValueError, match="one value per target in scope"):
        env.set_target_values(agent, {})
    env.set_target_values(agent, {t: 1.0 for t in crew.scope})
    assert agent not in env.pending_values


def test_same_seed_same_decisions():
    def run():
        hl = TargetEvaluationEnv(Navigator, max_time_s=SHORT_S)
        obs, _ = hl.reset(seed=5)
        trace = [obs.tobytes()]
        rng = np.random.default_rng(1)
        while True:
            obs, r, terminated, truncated, _ = hl.step(rng.uniform(-1, 1, 2))
            trace.append((obs.tobytes(), r))
            if terminated or truncated:
                return trace
    assert run() == run()


def test_the_crew_values_highest_the_target_nearest_the_desired_position():
    hl = TargetEvaluationEnv(Navigator, max_time_s=SHORT_S)
    given = []
    inner_set = hl.env.set_target_values
    hl.env.set_target_values = lambda agent, values: (given.append(dict(values)),
                                                      inner_set(agent, values))
    hl.reset(seed=0)
    env = hl.env
    crew = env.site.crews[env.agent_index[hl.deciding_agent]]
    half_w, half_h = env.case.plane.half_extents
    east = max(crew.scope, key=lambda t: env.site.target_xy[t][0])
    x, y = env.site.target_xy[east]
    given.clear()
    hl.step(np.array([x / half_w, y / half_h]))
    values = given[0]
    assert max(values, key=values.get) == east and values[east] == 1.0
    assert min(values.values()) == 0.5  # as_target_values: the scope spread over [0.5, 1]
