"""The logistics role (``cmdp_pymunk.logistics``, issue 42 item 6): when a fetching crew asks for
the next lift, on both floors and in the stage-2 decision loop."""

import hashlib

import numpy as np
import pytest
from conftest import fetching_env, tiny_dict

import cmdp_pymunk
from cmdp_pymunk import construct
from cmdp_pymunk.adapters.decision_loop import DecisionLoop, make_decision_env
from cmdp_pymunk.cases.load import REORDER_CASE, case_from_dict
from cmdp_pymunk.evaluate import make_evaluator
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.logistics import (
    CraneIdle,
    FromOutside,
    Levels,
    Logistics,
    Never,
    ReorderPoint,
    make_logistics,
)

M1 = 2  # the tiny case's first rebar crew


def schedule(engine) -> list[tuple]:
    return [(e.time_s, e.kind, e.crew, e.subject, e.detail) for e in engine.log.events]


def event_play(case, logistics, seed=0):
    base = cmdp_pymunk.load_case(None)
    floor = EventFloor(case, evaluator=make_evaluator("priority"), stall_s=3600.0,
                       calibration=calibration_for(base), logistics=logistics)
    floor.reset(seed)
    floor.run()
    assert floor.makespan_s is not None
    return floor


class Script:
    """A role with given levels that answers from a list, recording each question."""

    def __init__(self, levels, answers):
        self._levels, self.answers, self.asked = tuple(levels), list(answers), []

    def levels(self, material):
        return self._levels

    def lift_now(self, crew, storage):
        self.asked.append((crew, storage))
        return self.answers.pop(0)



# -- the decision levels (construct) ----------------------------------------------------------

def test_asked_once_at_each_level_and_a_yes_asks_the_crane():
    env = fetching_env(stock=0.45)
    site, storage = env.engine.site, env.engine.site.storages[0]
    role = Script(levels=(0.4, 0.3), answers=[False, True])
    for _ in range(4):  # by hand: 0.45 - 4 x 0.01 = 0.41 > 0.4
        construct.advance(site, env.engine.positions, env.log, 1.0, logistics=role)
    assert role.asked == []
    construct.advance(site, env.engine.positions, env.log, 1.0, logistics=role)  # 0.40
    assert role.asked == [(M1, 0)] and storage.asked_at == 0.4 and not storage.lift_pending
    for _ in range(9):  # 0.31: still above the next level, not asked again at 0.4
        construct.advance(site, env.engine.positions, env.log, 1.0, logistics=role)
    assert len(role.asked) == 1 and site.crane.current is None
    construct.advance(site, env.engine.positions, env.log, 1.0, logistics=role)  # 0.30: yes
    assert len(role.asked) == 2 and storage.lift_pending
    assert site.crane.current.kind == "material" and site.crane.remaining_s == 60.0
    for _ in range(60):  # the lift lands 60 s later: asked at every level again
        construct.advance(site, env.engine.positions, env.log, 1.0, logistics=role)
    assert not storage.lift_pending and storage.asked_at == float("inf")


def test_a_jump_past_two_levels_asks_once_at_the_lower():
    env = fetching_env(stock=0.45)
    site = env.engine.site
    role = Script(levels=(0.4, 0.3), answers=[False])
    construct.advance(site, env.engine.positions, env.log, 16.0, logistics=role)  # 0.29
    assert role.asked == [(M1, 0)] and site.storages[0].asked_at == 0.3


def test_the_event_floor_jumps_to_the_next_level_not_yet_asked():
    env = fetching_env(stock=0.45)
    site, storage = env.engine.site, env.engine.site.storages[0]
    levels = {"bars": (0.4, 0.3)}.get
    # by hand: the load is full after 20 s (0.2 at 0.01 m3/s); 0.4 is 5 s away, 0.3 15 s
    assert construct.next_change_in(site, env.engine.positions, levels=levels) == \
        pytest.approx(5.0)
    storage.asked_at = 0.4
    assert construct.next_change_in(site, env.engine.positions, levels=levels) == \
        pytest.approx(15.0)
    storage.lift_pending = True  # no question while a lift is on its way: the load is next
    assert construct.next_change_in(site, env.engine.positions, levels=levels) == \
        pytest.approx(20.0)
    # the case's reorder point gives way to the role: none of it without levels
    assert construct.next_change_in(site, env.engine.positions, levels=lambda m: ()) == \
        pytest.approx(20.0)


# -- Never and ReorderPoint against the case's own rules --------------------------------------

def test_never_plays_eq9s_schedule_exactly_on_the_event_floor(priority_floor):
    case = cmdp_pymunk.load_case(None)
    assert schedule(event_play(case, Never())) == schedule(priority_floor)
    # it replaces the case's reorder point: the reorder floor under Never is the paper's
    assert schedule(event_play(cmdp_pymunk.load_case(REORDER_CASE), Never())) == \
        schedule(priority_floor)


@pytest.mark.slow  # about 7 s: a whole pymunk floor of the built-in case
def test_never_plays_the_golden_schedule_on_the_pymunk_floor(tmp_path, monkeypatch):
    """``cmdp-simulate`` seed 0 with every engine given ``Never``: the recorded bytes."""
    from test_golden import golden, simulate_seeds

    import cmdp_pymunk.engine as engine_module

    made = []

    def never_by_default(spec):
        made.append(spec)
        return Never() if spec is None else spec
    monkeypatch.setattr(engine_module, "make_logistics", never_by_default)
    assert simulate_seeds(0, 1, tmp_path)["0"] == golden()["seeds"]["0"]
    assert made  # the run went through the role


def test_a_reorder_point_role_is_the_cases_reorder_point_on_the_event_floor():
    base, reorder = cmdp_pymunk.load_case(None), cmdp_pymunk.load_case(REORDER_CASE)
    rule = schedule(event_play(reorder, None, seed=1))
    assert schedule(event_play(base, ReorderPoint(lifts=0.5), seed=1)) == rule
    points = {m: x.reorder_at for m, x in reorder.materials.items()}
    assert schedule(event_play(base, ReorderPoint(at=points), seed=1)) == rule
    assert rule != schedule(event_play(base, None, seed=1))  # the point matters here


@pytest.mark.parametrize("at", [0.25, 0.4])
def test_a_reorder_point_role_is_the_cases_reorder_point_on_the_pymunk_floor(at):
    from conftest import play, play_floor, scripted_floor

    data = tiny_dict()
    data["materials"]["bars"]["reorder_at"] = at
    by_case = play_floor(case=case_from_dict(data, "tiny.toml"))
    env, navigator = scripted_floor(case=case_from_dict(tiny_dict(), "tiny.toml"))
    env.engine.logistics = ReorderPoint(at=at)
    env.reset(seed=0)
    navigator.reset(0)
    by_role = play(env, navigator)
    assert by_role.engine.makespan_s is not None
    assert schedule(by_role.engine) == schedule(by_case.engine)
    assert any(e.kind == "crane_request" and e.detail == "material"
               for e in by_case.engine.log.events)


def test_never_plays_the_tiny_cases_schedule_on_the_pymunk_floor():
    from conftest import play, play_floor, scripted_floor

    plain = play_floor(case=case_from_dict(tiny_dict(), "tiny.toml"))
    env, navigator = scripted_floor(case=case_from_dict(tiny_dict(), "tiny.toml"))
    env.engine.logistics = Never()
    env.reset(seed=0)
    navigator.reset(0)
    assert schedule(play(env, navigator).engine) == schedule(plain.engine)


# -- a state rule, validation ------------------------------------------------------------------

def test_crane_idle_lifts_only_when_the_crane_has_nothing_to_do():
    floor = EventFloor(cmdp_pymunk.load_case(None), evaluator="priority", logistics=CraneIdle())
    floor.reset(0)
    assert floor.logistics.levels("rebars") == pytest.approx((1.125, 0.75, 0.375))  # 1.5 m3
    assert CraneIdle().lift_now(floor, 0, 0) is True
    floor.site.crane.queue.append(object())
    assert CraneIdle().lift_now(floor, 0, 0) is False


def test_roles_that_do_not_fit_are_refused_with_the_fix():
    with pytest.raises(ValueError, match="fix: name one of .*rebars"):
        EventFloor(cmdp_pymunk.load_case(None), logistics=ReorderPoint(at={"rebar": 0.7}))
    with pytest.raises(ValueError, match="either as at="):
        ReorderPoint()
    with pytest.raises(ValueError, match="fix: a stock of 0 or more"):
        ReorderPoint(at=-1.0)
    with pytest.raises(ValueError, match="fix: one or more shares"):
        CraneIdle(shares=())
    with pytest.raises(TypeError, match="logistics.Never"):
        make_logistics("never")
    assert isinstance(Never(), Logistics) and isinstance(FromOutside(), Levels)


def test_only_a_crew_asked_may_answer_and_clones_share_the_role():
    role = Never()
    floor = EventFloor(cmdp_pymunk.load_case(None), evaluator="priority", logistics=role)
    floor.reset(0)
    with pytest.raises(ValueError, match="fix: answer only crews in engine.lift_questions"):
        floor.answer_lift(0, True)
    floor.advance(None, until=lambda: floor.site.time_s > 100)
    assert floor.clone().logistics is role


# -- the stage-2 decision loop -----------------------------------------------------------------

def loop_signature(loop: DecisionLoop) -> str:
    return hashlib.sha256(repr(schedule(loop.engine)).encode()).hexdigest()


def play_loop(loop: DecisionLoop, seed: int, answer) -> int:
    """Eq. 9's choices (the teacher's) for the targets, ``answer()`` for the lifts; returns
    the lift decisions made."""
    loop.reset(seed)
    lifts = 0
    while True:
        if loop.deciding_lift is not None:
            lifts += 1
            out = loop.lift(answer())
        else:
            out = loop.decide(loop.teacher_action())
        if out.terminated or out.truncated:
            assert out.terminated
            return lifts


def test_the_flag_off_leaves_every_space_as_it_was():
    env = make_decision_env(fidelity="event")
    assert env.action_space.shape == (2,) and env.floor.engine.logistics is None
    on = make_decision_env(fidelity="event", logistics=True)
    assert on.action_space.shape == (3,)
    assert on.observation_space.shape[0] == env.observation_space.shape[0] + 4
    assert on.floor.actor_size == env.floor.actor_size + 4


@pytest.mark.parametrize("seed", [0, 1])
def test_answering_no_to_every_lift_plays_the_papers_c7_on_the_pymunk_floor(seed):
    case = case_from_dict(tiny_dict(), "tiny.toml")
    off, on = (DecisionLoop(case, fidelity="pymunk", park_idle=True, logistics=flag)
               for flag in (False, True))
    assert play_loop(off, seed, None) == 0
    assert play_loop(on, seed, lambda: False) > 0  # the loop did ask
    assert loop_signature(on) == loop_signature(off)


def test_the_env_with_logistics_steps_to_the_end_with_random_actions():
    env = make_decision_env(fidelity="event", logistics=True)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=5)
    lifts, asked_yes = 0, 0
    for _ in range(2000):
        if env.floor.deciding_lift is not None:
            lifts += 1
            assert obs[env.floor.actor_size - 4] == 1.0  # the lift decision's flag
        action = env.action_space.sample()
        asked_yes += env.floor.deciding_lift is not None and action[2] > 0
        obs, reward, terminated, truncated, info = env.step(action)
        assert np.isfinite(reward)
        if terminated or truncated:
            break
        assert env.observation_space.contains(obs)
    assert terminated and info["makespan_s"] is not None
    assert lifts > 0 and asked_yes > 0
