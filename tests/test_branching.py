"""Common random numbers and branching: per-task pace streams, ``Engine.clone``, scenarios."""

from __future__ import annotations

import pytest
from conftest import place, play, scripted_floor

from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from cmdp_pymunk import CMDPEnv
from cmdp_pymunk.construct import draw_pace
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import NearestFirstEvaluator
from cmdp_pymunk.streams import EXPECTED, ExpectedDraws, RandomStreams
from cmdp_pymunk.world import STORAGE


def floor(evaluator=None, seed: int = 0):
    return scripted_floor(evaluator or PriorityEvaluator(), seed=seed)


def run(env, navigator, until_s: float | None = None) -> None:
    play(env, navigator, until_s)


def clone(env, scenario=None):
    """A branch of the env's floor, driven by a new env over the cloned engine: (env,
    navigator); the scripted navigator's plans come along in ``engine.memory``."""
    branch = env.engine.clone(scenario)
    twin = CMDPEnv(env.case, evaluator=branch.evaluator, park_idle=True, blind=True)
    twin.engine = branch
    twin.agents = list(twin.possible_agents)
    return twin, Navigator()


def paces(env) -> dict[str, float]:
    return {t.id: t.pace for t in env.engine.site.tasks if t.started_s >= 0}


def test_a_task_pace_comes_from_its_own_stream():
    # the same (seed, task) gives the same generator whatever was drawn before
    a, b = RandomStreams(7), RandomStreams(7)
    b.pace(3).random()
    assert a.pace(5).random() == b.pace(5).random()
    assert a.pace(5).random() != a.pace(6).random()
    assert RandomStreams(7).pace(5).random() != RandomStreams(8).pace(5).random()
    assert RandomStreams(7, scenario=1).pace(5).random() != a.pace(5).random()
    assert RandomStreams(7, scenario=1).pace(5).random() == \
        RandomStreams(7).with_scenario(1).pace(5).random()
    with pytest.raises(ValueError, match="seed must be an int >= 0"):
        RandomStreams(-1)
    with pytest.raises(ValueError, match="scenario must be an int >= 0"):
        RandomStreams(1, scenario="a")


def test_two_strategies_on_one_seed_meet_the_same_paces():
    priority, nav_p = floor(PriorityEvaluator(), seed=3)
    nearest, nav_n = floor(NearestFirstEvaluator(), seed=3)
    run(priority, nav_p, 8000.0)
    run(nearest, nav_n, 8000.0)
    a, b = paces(priority), paces(nearest)
    both = a.keys() & b.keys()
    assert len(both) >= 5 and a.keys() != b.keys()  # different orders, shared tasks
    assert all(a[t] == b[t] for t in both)
    # and each pace is Table 3's draw from the task's own stream
    site = priority.engine.site
    for task in site.tasks:
        if task.id in both:
            crew = site.crews[task.crew]
            assert task.pace == draw_pace(RandomStreams(3).pace(task.index), crew, task)


def test_a_clone_continued_runs_exactly_as_the_original():
    env, navigator = floor()
    run(env, navigator, 3000.0)
    env2, navigator2 = clone(env)
    engine = env2.engine
    assert engine is not env.engine and engine.memory["navigator"].engine is engine
    assert engine.site is not env.engine.site and engine.world is not env.engine.world
    run(env, navigator, 9000.0)
    run(env2, navigator2, 9000.0)
    assert env.log.events == env2.log.events
    assert env.engine.positions == env2.engine.positions
    assert [c.stats.congestion_entries for c in env.engine.site.crews] == \
        [c.stats.congestion_entries for c in env2.engine.site.crews]


def test_scenarios_change_only_the_paces_of_tasks_not_yet_started():
    env, navigator = floor()
    run(env, navigator, 4000.0)
    started = paces(env)
    branches = [clone(env, scenario=k) for k in (1, 2)]
    for env_k, nav_k in branches:
        run(env_k, nav_k, 9000.0)
    one, two = paces(branches[0][0]), paces(branches[1][0])
    assert all(one[t] == started[t] == two[t] for t in started)  # drawn before the branch
    later = (one.keys() & two.keys()) - started.keys()
    assert len(later) >= 3
    assert all(one[t] != two[t] for t in later)
    site = branches[0][0].engine.site
    for task in site.tasks:
        if task.id in later:
            stream = RandomStreams(0, scenario=1).pace(task.index)
            assert task.pace == draw_pace(stream, site.crews[task.crew], task)


def test_the_expected_scenario_gives_the_tasks_not_yet_started_their_mean_pace():
    env, navigator = floor()
    run(env, navigator, 4000.0)
    started = paces(env)
    branch, nav = clone(env, scenario=EXPECTED)
    run(branch, nav, 9000.0)
    site = branch.engine.site
    later = paces(branch).keys() - started.keys()
    assert len(later) >= 3 and all(paces(branch)[t] == started[t] for t in started)
    for task in site.tasks:
        if task.id in later:
            spec = site.crews[task.crew].spec
            if spec.by_duration:  # one unit of work in the mean duration, by hand
                assert task.pace == 1.0 / (spec.duration_mean_min * 60.0)
            else:                 # the mean efficiency per minute, per second
                assert task.pace == spec.efficiency_mean_per_min / 60.0
    # e.g. a crew type of 11.8 min by duration: pace 1 / 708 work per second
    assert ExpectedDraws().normal(11.8, 1.2) == 11.8
    with pytest.raises(ValueError, match="EXPECTED"):
        RandomStreams(0, scenario=-2)


def test_clone_refuses_an_episode_not_started_or_finished(tiny_case):
    engine = Engine(tiny_case, stage=2, evaluator=NearestFirstEvaluator(), seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        engine.clone()
    engine.reset(seed=0)
    engine.site.tasks_ended = len(engine.site.tasks)
    with pytest.raises(ValueError, match="episode has ended"):
        engine.clone()


def test_a_contact_that_outlives_a_rebuild_is_not_counted_twice(tiny_env):
    world = tiny_env.engine.world
    storage = tiny_env.engine.site.storages[0]
    x0, y0, x1, y1 = storage.rect
    place(tiny_env, 0, (x0 + x1) / 2, (y0 + y1) / 2)
    world.desired[0] = [0.1, 0.0, 0.0]  # move, so the physics steps
    world.step(1.0, 2)
    assert world.take_contacts(0)[STORAGE] == 1  # entered: counted once
    world.__setstate__(world.__getstate__())
    world.desired[0] = [0.1, 0.0, 0.0]
    world.step(1.0, 2)
    assert world.take_contacts(0)[STORAGE] == 0  # still inside after the rebuild


def test_a_pace_stream_gives_its_generators_draws_draw_for_draw():
    """``PaceStream`` keeps each stream's first standard normal per process: a first normal
    from it is numpy's own to the bit, and any later draw continues the stream as the
    generator would."""
    import numpy as np

    from cmdp_pymunk.streams import PACE, PaceStream

    rs = np.random.default_rng(5)
    for _ in range(300):
        seed, task = int(rs.integers(0, 10**6)), int(rs.integers(0, 200))
        loc, scale = float(rs.uniform(0.05, 90.0)), float(rs.uniform(0.0, 25.0))
        streams = RandomStreams(seed)
        plain = streams.generator(PACE, task)
        kept = streams.pace(task)
        assert isinstance(kept, PaceStream)
        assert kept.normal(loc, scale) == plain.normal(loc, scale)
        assert kept.normal(loc, scale) == plain.normal(loc, scale)  # the second draw
        assert kept.random() == plain.random()  # and anything else after it
    fresh, plain = RandomStreams(9).pace(4), RandomStreams(9).generator(PACE, 4)
    assert fresh.random() == plain.random() and fresh.normal(1.0, 2.0) == plain.normal(1.0, 2.0)
    again, plain = RandomStreams(9).pace(4), RandomStreams(9).generator(PACE, 4)
    assert again.normal(3.0, 0.5) == plain.normal(3.0, 0.5)  # the kept draw, a fresh stream


def test_the_streams_seeding_is_numpys_on_every_key_shape():
    """``streams._first_normals`` hashes keys as numpy's SeedSequence and seeds PCG64 as
    numpy does: the first normal of 3,000 keys of every shape a floor asks (an episode's
    seed, OS entropy of 128 bits, a scenario's and the expected future's longer keys), in
    blocks as a floor asks them, is numpy's to the bit, and this numpy agrees (else the
    streams fall back to numpy's path)."""
    import numpy as np

    from cmdp_pymunk import streams

    assert streams._numpy_agrees()
    rs = np.random.default_rng(11)
    for n in range(100):
        entropy = [0, int(rs.integers(0, 2**31)), int(rs.integers(0, 2**63)) * 2**64 + n][n % 3]
        tail = [(), (2,), (1, int(rs.integers(0, 1000)))][n % 3 if n % 7 else 0]
        first = int(rs.integers(0, 5000))
        keys = [(entropy, streams.PACE, first + i, *tail) for i in range(30)]
        assert streams._first_normals(keys) == [streams._numpy_first_normal(k) for k in keys]
    streams._KEPT.clear()
    key = (3, streams.PACE, 70)
    assert streams._first_normal(key) == streams._numpy_first_normal(key)
    assert (3, streams.PACE, 64) in streams._KEPT and (3, streams.PACE, 95) in streams._KEPT
