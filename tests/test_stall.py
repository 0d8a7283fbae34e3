"""The env's stall guard: an episode in which no task moves on is truncated and flagged."""

import math

import numpy as np
import pytest
from conftest import run_episode, tiny_dict

from agents.steering import steer_all
from cmdp_pymunk import parallel_env
from cmdp_pymunk.cases.load import case_from_dict

STILL = (0, 1, 1)  # no forward, no lateral, no turn


def tiny_env(**kwargs):
    return parallel_env(case=case_from_dict(tiny_dict()), **kwargs)


def test_crews_that_never_move_are_stopped_at_stall_s_with_the_flag():
    env = tiny_env(stall_s=50, seed=0)
    env.reset(seed=0)
    calls = 0
    while env.agents:
        _, _, terms, truncs, infos = env.step({a: STILL for a in env.agents})
        calls += 1
    # nothing ever progressed, from t = 0: stopped at exactly t = 50, not at the 5,000 s limit
    assert env.engine.site.time_s == 50 and calls == 50
    assert all(truncs.values()) and not any(terms.values())
    assert all(i["stalled"] and i["TimeLimit.truncated"] for i in infos.values())
    assert env.stalled == {"after_s": 50.0, "time_s": 50.0}


def test_lean_infos_carry_the_stall_flag_too():
    env = tiny_env(stall_s=30, seed=0, lean_infos=True)
    env.reset(seed=0)
    while env.agents:
        *_, infos = env.step({a: STILL for a in env.agents})
    assert all(i.get("stalled") and i.get("TimeLimit.truncated") for i in infos.values())


def test_a_plain_time_out_is_not_flagged_as_a_stall():
    env = tiny_env(max_time_s=20, stall_s=100)
    env.reset(seed=0)
    while env.agents:
        *_, infos = env.step({a: STILL for a in env.agents})
    assert env.stalled is None
    assert all(i["TimeLimit.truncated"] and "stalled" not in i for i in infos.values())


def test_the_guard_changes_nothing_in_an_episode_that_progresses():
    plain, guarded = tiny_env(stage=2), tiny_env(stage=2, stall_s=200)
    trace_a = run_episode(plain, 3, steer_all)
    trace_b = run_episode(guarded, 3, steer_all)
    assert guarded.engine.site.done and guarded.stalled is None
    assert trace_a == trace_b


def test_the_guard_stops_inside_an_idle_jump():
    """A single step() call that jumps idle seconds must not run past the guard: here every
    crew stands parked and the task areas never change, so one call would jump to the limit."""
    env = tiny_env(stall_s=40, park_idle=True, max_time_s=5000)
    env.reset(seed=0)
    for crew in env.engine.site.crews:  # no crew has anything to do: all parked, nothing progresses
        crew.scope, crew.values, crew.scope_version = {}, {}, env.engine.site.version
    while env.agents:
        *_, truncs, infos = env.step({a: STILL for a in env.agents})
    assert env.engine.site.time_s <= 41


@pytest.mark.parametrize("bad", [0, -5, math.nan, math.inf])
def test_bad_stall_s_is_refused(bad):
    with pytest.raises(ValueError, match="stall_s"):
        tiny_env(stall_s=bad)


@pytest.mark.parametrize("bad", [0, -1, math.nan, math.inf])
def test_bad_max_time_s_is_refused(bad):
    with pytest.raises(ValueError, match="max_time_s"):
        tiny_env(max_time_s=bad)


def test_stall_reaches_sb3_through_supersuit():
    import supersuit as ss

    env = tiny_env(stall_s=15, lean_infos=True)
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    venv.reset(seed=0)
    actions = np.array([list(STILL)] * venv.num_envs)
    for _ in range(100):
        _, _, terms, truncs, infos = venv.step(actions)
        if truncs.any():
            break
    assert truncs.all() and all(i.get("stalled") for i in infos)
