"""The PettingZoo env: API, determinism over whole episodes, the idle jump, stages, time-outs."""

import numpy as np
import pytest
from conftest import run_episode, tiny_dict

from agents.steering import steer_all
from cmdp_pymunk import parallel_env
from cmdp_pymunk.cases.load import case_from_dict
from cmdp_pymunk.observe import evaluation_size
from cmdp_pymunk.state import CrewStatus


def tiny_env(**kwargs):
    return parallel_env(case=case_from_dict(tiny_dict()), **kwargs)


def schedule(env):
    return [e for e in env.log.events if e.kind != "reach"]


def test_parallel_api_test():
    from pettingzoo.test import parallel_api_test

    parallel_api_test(tiny_env(seed=0), num_cycles=200)


def test_builtin_case_spaces_and_agents():
    env = parallel_env(seed=0)
    obs, infos = env.reset(seed=0)
    assert env.agents == ["JCC-1", "HIC-1", "GC-1", "RC-1", "RC-2", "FC-1", "FC-2"]
    # (12 + 16) rays x 4 values + 3 velocity values + 4 target-memory values (the built-in
    # case turns the memory on)
    assert env.observation_space("RC-1").shape == (119,)
    assert list(env.action_space("RC-1").nvec) == [4, 3, 3]
    assert env.observation_space("RC-1") is env.observation_space("RC-1")
    assert all(o.shape == (119,) and o.dtype == np.float32 for o in obs.values())
    # O^e (stage 2): 5 floats of the crew's, 12 per target (36 components, 3 storages, outlet)
    assert evaluation_size(env.case) == 5 + 12 * (36 + 3 + 1)


def test_whole_episode_is_deterministic_and_finishes():
    env_a, env_b = tiny_env(stage=2), tiny_env(stage=2)
    trace_a = run_episode(env_a, 3, steer_all)
    trace_b = run_episode(env_b, 3, steer_all)
    assert env_a.engine.site.done
    assert trace_a == trace_b
    assert env_a.log.events == env_b.log.events
    # another seed draws other durations (X tasks have a spread): another schedule
    env_c = tiny_env(stage=2)
    run_episode(env_c, 4, steer_all)
    assert schedule(env_c) != schedule(env_a)


def test_activity_events_follow_every_state_change():
    """The Gantt chart's activity log agrees with the crew states: at every second in which a
    crew's state changed, its activity at the end of that second matches the last state."""
    from agents.navigator import Navigator

    env = tiny_env(park_idle=True)
    nav = Navigator()
    run_episode(env, 1, lambda e: e.agent_actions(nav, None))
    final_state, activity_at = {}, {}
    for e in env.log.events:
        if e.kind == "crew_state":
            final_state[(e.crew, e.time_s)] = e.subject
        elif e.kind == "activity":
            activity_at[(e.crew, e.time_s)] = e.subject
    checked = 0
    for key, state in final_state.items():
        if state in ("tasking", "fetching", "waiting", "left") and key[1] > 0:
            assert activity_at.get(key) == state, (key, state, activity_at.get(key))
            checked += 1
    assert checked >= 8


def test_reset_without_seed_keeps_the_random_streams():
    env = tiny_env()
    env.reset(seed=5)
    first = env.engine.streams.pace(0).random()
    env.reset(seed=5)
    assert env.engine.streams.pace(0).random() == first
    env.reset()
    assert env.engine.streams.pace(0).random() == first  # None keeps the seed's streams
    env.reset(seed=6)
    assert env.engine.streams.pace(0).random() != first


def test_idle_jump_gives_the_same_schedule_as_stepping():
    jumping, stepping = tiny_env(jump_idle=True), tiny_env(jump_idle=False)
    trace_jump = run_episode(jumping, 1, steer_all)
    trace_step = run_episode(stepping, 1, steer_all)
    assert jumping.engine.site.done and stepping.engine.site.done
    assert schedule(jumping) == schedule(stepping)
    assert jumping.engine.site.time_s == stepping.engine.site.time_s
    assert len(trace_jump) < len(trace_step)  # the jump skipped seconds in single calls
    assert max(e for _, _, _, el in trace_jump for e in el.values()) > 1


def test_stage_1_has_no_durations_stock_or_crane_wait():
    env = tiny_env(stage=1)
    run_episode(env, 0, steer_all)
    assert env.engine.site.done
    kinds = [e.kind for e in env.log.events]
    assert "crane_request" not in kinds  # no crane waits
    # stockpiles never drawn down
    assert all(s.stock == s.capacity for s in env.engine.site.storages)
    paused = {e.subject for e in env.log.events if e.kind == "task_pause"}
    assert paused == {"M-C"}  # 0.3 m3 of bars for a crew that carries 0.2: one trip between
    assert sum(c.stats.material_trips for c in env.engine.site.crews) >= 2
    for task in env.engine.site.tasks:
        if task.id not in paused:
            assert task.ended_s - task.started_s == 1.0  # done the step after it was initiated
    fetching = [e for e in env.log.events if e.kind == "crew_state" and e.subject == "fetching"]
    for e in fetching:  # a fetch loads the crew at once: reaching again the next step
        after = [f for f in env.log.events if f.crew == e.crew and f.kind == "crew_state"
                 and f.time_s > e.time_s]
        assert after and after[0].time_s == e.time_s + 1


def test_time_limit_truncates_with_the_sb3_flag():
    env = tiny_env(max_time_s=20)
    env.reset(seed=0)
    while env.agents:
        obs, rew, terms, truncs, infos = env.step({a: (0, 1, 1) for a in env.agents})
    assert all(truncs.values()) and not any(terms.values())
    assert all(i["TimeLimit.truncated"] for i in infos.values())
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


def test_crews_that_do_not_move_get_a_constant_observation_and_no_reward():
    env = tiny_env()
    env.reset(seed=0)
    still = (CrewStatus.TASKING, CrewStatus.WAITING, CrewStatus.LEFT)
    checked = 0
    while env.agents:
        before = {a: env.engine.site.crews[env.agent_index[a]].status for a in env.agents}
        obs, rew, *_ = env.step(steer_all(env))
        for agent in obs:
            crew = env.engine.site.crews[env.agent_index[agent]]
            if crew.status in still:
                assert not obs[agent].any()
            if before[agent] in still:  # it stood still the whole step: nothing to reward
                assert rew[agent] == 0.0
                checked += 1
    assert checked > 10


def test_evaluation_reward_terms_are_reported():
    env = tiny_env()
    env.reset(seed=0)
    _, _, _, _, infos = env.step({a: (0, 1, 1) for a in env.agents})
    terms = infos["K-1"]["evaluation_terms"]
    assert set(terms) == {"idle_pre", "idle_area", "efficiency", "episode", "path"}
    assert terms["idle_pre"] < 0  # K-1 and both M crews wait for predecessors at the start
    assert infos["K-1"]["evaluation_reward"] == pytest.approx(sum(terms.values()))


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="stage"):
        tiny_env(stage=3)
    with pytest.raises(ValueError, match="render_mode"):
        tiny_env(render_mode="human")


def test_idle_jump_with_parked_crews_gives_the_same_schedule():
    from agents.navigator import Navigator

    runs = []
    for jump in (True, False):
        env = tiny_env(jump_idle=jump, park_idle=True, seed=2)
        nav = Navigator()
        run_episode(env, 2, lambda e, nav=nav: e.agent_actions(nav, None))
        assert env.engine.site.done
        runs.append(env)
    assert schedule(runs[0]) == schedule(runs[1])


def test_lean_infos_hold_only_nonzero_step_counts():
    full = parallel_env(seed=0)
    lean = parallel_env(seed=0, lean_infos=True)
    full.reset(seed=0)
    _, infos = lean.reset(seed=0)
    assert all(info == {} for info in infos.values())
    for _ in range(30):
        actions = {a: (3, 1, 0) for a in full.agents}
        *_, full_infos = full.step(actions)
        *_, lean_infos = lean.step(actions)
        for agent, info in lean_infos.items():
            expected = {k: v for k, v in full_infos[agent]["step_stats"].items() if v}
            assert info == ({"step_stats": expected} if expected else {})


@pytest.mark.parametrize("lean", [False, True])
def test_time_out_reaches_sb3_through_supersuit(lean):
    """SuperSuit merges the reset infos over the last step's: the flag must survive that."""
    import supersuit as ss

    env = tiny_env(max_time_s=20)
    env.lean_infos = lean
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    venv.reset(seed=0)
    actions = np.array([[0, 1, 1]] * venv.num_envs)
    for _ in range(100):
        _, _, terms, truncs, infos = venv.step(actions)
        if truncs.any():
            break
    assert truncs.all() and not terms.any()
    assert all(i.get("TimeLimit.truncated") and "terminal_observation" in i for i in infos)
