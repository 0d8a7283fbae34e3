"""A material's reorder point (``Material.reorder_at``): the crane's next lift asked for while a
crew still loads, on both floors, and its validation."""

import pytest
from conftest import fetching_env, tiny_dict

import cmdp_pymunk
from cmdp_pymunk import construct
from cmdp_pymunk.cases.load import CaseError, case_from_dict
from cmdp_pymunk.evaluate import make_evaluator
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.eventfloor.calibration import fingerprint
from cmdp_pymunk.state import CrewStatus

M1 = 2  # the tiny case's first rebar crew



def test_a_lift_is_asked_for_at_the_reorder_point_and_the_crew_keeps_loading():
    env = fetching_env(reorder_at=0.3, stock=0.45)
    site, crew = env.engine.site, env.engine.site.crews[M1]
    for _ in range(14):  # by hand: 0.45 - 14 x 0.01 = 0.31 > 0.3
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert not site.storages[0].lift_pending and site.crane.current is None
    construct.advance(site, env.engine.positions, env.log, 1.0)  # 15 s: 0.30, the point
    assert site.storages[0].lift_pending and crew.status == CrewStatus.FETCHING
    assert site.crane.current.kind == "material" and site.crane.remaining_s == 60.0
    assert crew.load == pytest.approx(0.15) and site.storages[0].stock == pytest.approx(0.3)
    for _ in range(5):  # the crew fills its load (0.2) and the lift is under way
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert crew.load == pytest.approx(0.2) and site.storages[0].stock == pytest.approx(0.25)
    for _ in range(55):  # 60 s after the request the lift lands: 0.25 + 0.5
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert site.storages[0].stock == pytest.approx(0.75) and not site.storages[0].lift_pending
    requests = [e for e in env.log.events if e.kind == "crane_request"]
    assert [(e.crew, e.subject, e.detail) for e in requests] == [("M-1", "S", "material")]


def test_without_a_reorder_point_the_storage_runs_dry_first():
    env = fetching_env(reorder_at=0.0, stock=0.45)
    site = env.engine.site
    for _ in range(20):
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert not site.storages[0].lift_pending and site.crane.current is None


def test_one_jump_of_many_seconds_asks_at_the_same_second_as_single_seconds():
    """What the event floor relies on: a step of dt seconds ending at the reorder point leaves
    the lift's countdown where 15 steps of one second leave it."""
    one, jump = fetching_env(0.45, reorder_at=0.3), fetching_env(0.45, reorder_at=0.3)
    for _ in range(15):
        construct.advance(one.engine.site, one.engine.positions, one.log, 1.0)
    construct.advance(jump.engine.site, jump.engine.positions, jump.log, 15.0)
    for env in (one, jump):
        assert env.engine.site.storages[0].lift_pending
        assert env.engine.site.crane.remaining_s == 60.0
        assert env.engine.site.storages[0].stock == pytest.approx(0.3)


def test_the_event_floor_stops_at_each_reorder_point(monkeypatch):
    """On the built-in floor's event floor with reorder points, every lift asked for early is
    asked for within a second of fetching of the point (the floor jumps to it), and the
    reinforcing crews wait for the crane less than without."""
    base = cmdp_pymunk.load_case(None)
    data = base.model_dump(mode="json")
    reorder = {"rebars": 0.75, "templates": 20.0, "struts": 3.0}
    for name, at in reorder.items():
        data["materials"][name]["reorder_at"] = at
    case = case_from_dict(data, "reorder.toml")
    assert fingerprint(case) == fingerprint(base)  # the same calibration holds
    seen = []
    due = construct.reorder_due

    def recording(site, storage):
        hit = due(site, storage)
        if hit:
            seen.append((storage.material, storage.stock))
        return hit
    monkeypatch.setattr(construct, "reorder_due", recording)

    def play(c):
        floor = EventFloor(c, evaluator=make_evaluator("priority"), stall_s=3600.0,
                           calibration=calibration_for(base))
        floor.reset(0)
        floor.run()
        assert floor.makespan_s is not None
        return floor
    early = play(case)
    assert {m for m, _ in seen} == set(reorder)
    fastest = max(m.acquire_per_min for m in base.materials.values()) / 60.0 * 2  # two crews
    assert all(reorder[m] - fastest <= stock <= reorder[m] + 1e-9 for m, stock in seen)
    plain = play(base)
    rc_waits = [sum(c.stats.crane_waits for c in f.site.crews if c.type == "RC")
                for f in (early, plain)]
    assert rc_waits[0] < rc_waits[1]


def test_a_reorder_point_at_or_above_a_storage_capacity_is_refused():
    data = tiny_dict()  # a copy
    data["materials"]["bars"]["reorder_at"] = 1.0  # the storage holds 1.0
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "tiny.toml")
    assert 'storages[0] "S"' in str(err.value) and "reorder_at" in str(err.value)
    assert "fix: set reorder_at below the capacity" in str(err.value)
    data["materials"]["bars"]["reorder_at"] = -0.1
    with pytest.raises(CaseError, match="reorder_at"):
        case_from_dict(data, "tiny.toml")


def test_the_reorder_floor_is_the_built_in_floor_with_reorder_points_at_half_a_lift():
    from cmdp_pymunk.cases.load import BUILTIN_CASE, REORDER_CASE

    plain, reorder = cmdp_pymunk.load_case(BUILTIN_CASE), cmdp_pymunk.load_case(REORDER_CASE)
    assert {m: x.reorder_at for m, x in reorder.materials.items()} == {
        m: x.crane_lift_quantity / 2 for m, x in plain.materials.items()}
    materials = {m: x.model_copy(update={"reorder_at": 0.0})
                 for m, x in reorder.materials.items()}
    assert reorder.model_copy(update={"materials": materials, "case": plain.case}) == plain
    assert calibration_for(reorder, REORDER_CASE).calibrated  # the built-in floor's serves it


def test_the_reorder_variant_is_registered():
    import pettingzoo

    env = pettingzoo.make("parallel", "cmdp/PrecastFloor-reorder-v1")
    assert env.case == cmdp_pymunk.load_case(cmdp_pymunk.REORDER_CASE)
    assert env.case.materials["rebars"].reorder_at == 0.75
