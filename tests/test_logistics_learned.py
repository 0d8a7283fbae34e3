"""The learned logistics role (``logistics.Learned``, issue 42 item 6): its file, its features and
decision on hand-made states, and the floors it plays."""

import json
from pathlib import Path

import pytest
from conftest import REBAR_CREW, fetching_env, tiny_dict

import cmdp_pymunk
from cmdp_pymunk.cases.load import case_from_dict
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.logistics import CraneIdle, Learned, Logistics, Never, linear_lift
from cmdp_pymunk.state import CraneRequest

MODEL = Path(__file__).resolve().parents[1] / "models" / "logistics_learned.json"


def schedule(engine) -> list[tuple]:
    return [(e.time_s, e.kind, e.crew, e.subject, e.detail) for e in engine.log.events]


def write(tmp_path, **changes) -> Path:
    data = {"kind": "cmdp-logistics-linear", "features": ["stock_lifts", "crane_busy"],
            "weights": [-1.0, -1.0], "bias": 0.6, "shares": [0.75, 0.5, 0.25], "meta": {}}
    data.update(changes)
    path = tmp_path / "rule.json"
    path.write_text(json.dumps(data))
    return path


def test_the_committed_model_loads_and_fits_the_built_in_case():
    role = Learned(MODEL)
    assert isinstance(role, Logistics)
    assert len(role.weights) == len(role.features) and role.meta["command"]
    floor = EventFloor(cmdp_pymunk.load_case(None), evaluator="priority", logistics=role)
    floor.reset(0)
    assert floor.logistics.levels("rebars") == pytest.approx(
        tuple(s * 1.5 for s in role.shares))  # rebars: 1.5 m3 a lift


def test_linear_lift_by_hand():
    # 0.6 - 1 x 0.9 - 1 x 0 = -0.3: no; 0.6 - 0.4 = 0.2: yes; on the boundary (0): no
    assert linear_lift((-1.0, -1.0), 0.6, (0.9, 0.0)) is False
    assert linear_lift((-1.0, -1.0), 0.6, (0.4, 0.0)) is True
    assert linear_lift((-1.0,), 0.5, (0.5,)) is False


def test_features_and_decision_on_hand_made_states(tmp_path):
    env = fetching_env(stock=0.45)  # the tiny case: bars lifted 0.5 m3 at a time, in 60 s
    engine = env.engine
    role = Learned.from_weights(
        ("stock_lifts", "crane_busy", "crane_queue", "crane_left_lifts", "fetching_here",
         "progress", "material=bars"), [0.0] * 7, 0.0)
    engine.logistics = role
    assert role.feature_values(engine, REBAR_CREW, 0) == pytest.approx(
        (0.9, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0))  # 0.45 / 0.5 lifts; M-1 alone fetches there
    rule = Learned(write(tmp_path))
    engine.logistics = rule
    assert rule.lift_now(engine, REBAR_CREW, 0) is False  # 0.6 - 0.9 = -0.3
    engine.site.storages[0].stock = 0.2
    assert rule.lift_now(engine, REBAR_CREW, 0) is True   # 0.6 - 0.4 = 0.2
    crane = engine.site.crane
    crane.current, crane.remaining_s = CraneRequest(0, "task", task=0), 30.0
    crane.queue.append(CraneRequest(1, "task", task=1))
    assert rule.lift_now(engine, REBAR_CREW, 0) is False  # 0.6 - 0.4 - 1 = -0.8
    role_values = role.feature_values(engine, REBAR_CREW, 0)
    assert role_values[1:4] == pytest.approx((1.0, 1.0, 0.5))  # 30 of a 60 s lift left


@pytest.mark.parametrize("change, error, match", [
    ({"kind": "other"}, ValueError, "entry 'kind' is 'other'.*fix"),
    ({"features": ["stock_lifts", "crane_bussy"]}, ValueError, r"features\[1\] 'crane_bussy'"),
    ({"weights": [1.0]}, ValueError, "1 numbers for 2 features; fix"),
    ({"bias": "high"}, ValueError, "bias 'high' is not a finite number"),
    ({"shares": []}, ValueError, "'shares'.*fix"),
])
def test_a_bad_file_is_refused_naming_the_entry_and_the_fix(tmp_path, change, error, match):
    path = write(tmp_path, **change)
    with pytest.raises(error, match=match) as err:
        Learned(path)
    assert str(path) in str(err.value)


def test_a_missing_or_broken_file_or_a_misfit_is_refused_with_the_fix(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such logistics model file; fix"):
        Learned(tmp_path / "none.json")
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    with pytest.raises(ValueError, match="broken.json: not a JSON file"):
        Learned(broken)
    path = write(tmp_path, features=["material=steel"], weights=[1.0])
    with pytest.raises(ValueError, match="'steel', not in case.*fix: fit the rule on this case"):
        EventFloor(cmdp_pymunk.load_case(None), logistics=Learned(path))


class Counting(Learned):
    """The learned role, counting the questions it is asked."""

    asked = 0

    def lift_now(self, engine, i, storage):
        Counting.asked += 1
        return super().lift_now(engine, i, storage)


def test_never_now_plays_nevers_schedule_on_the_pymunk_floor(tmp_path):
    """The issue's test: with the learned role's answer never "now" the floor is c7's."""
    from conftest import play, scripted_floor

    floors = []
    for role in (Never(), Counting(write(tmp_path, weights=[0.0, 0.0], bias=-1.0))):
        env, navigator = scripted_floor(case=case_from_dict(tiny_dict(), "tiny.toml"))
        env.engine.logistics = role
        env.reset(seed=0)
        navigator.reset(0)
        floors.append(play(env, navigator).engine)
    assert floors[1].makespan_s is not None and Counting.asked > 0  # it was asked, said no
    assert schedule(floors[1]) == schedule(floors[0])


def test_started_as_crane_idle_it_plays_crane_idles_schedule():
    """The search's start (bias 0.5 a material, -1 on crane_busy and crane_queue) is
    CraneIdle: the same event floor to the byte."""
    from training.research.logistics_search import FEATURES, START

    case = cmdp_pymunk.load_case(None)
    start = Learned.from_weights(FEATURES, [START.get(f, 0.0) for f in FEATURES], 0.0)
    floors = []
    for role in (CraneIdle(), start):
        floor = EventFloor(case, evaluator="priority", stall_s=3600.0,
                           calibration=calibration_for(case), logistics=role)
        floor.reset(1)
        floor.run()
        floors.append(floor)
    assert floors[0].makespan_s is not None
    assert schedule(floors[1]) == schedule(floors[0])


def test_the_search_writes_a_model_that_loads(tmp_path):
    from training.research.logistics_search import main

    out = tmp_path / "m.json"
    assert main(["--seeds", "3000", "--select", "3100", "--generations", "1", "--popsize", "2",
                 "--evaluator", "priority", "--out", str(out)]) == 0
    role = Learned(out)
    assert role.meta["selection"]["mean_makespan_s"]["never"] > 0
    assert (tmp_path / "m.history.csv").read_text().count("\n") == 1 + 1 + 2  # start + 2
    with pytest.raises(SystemExit):
        main(["--seeds", "3000-3001", "--select", "3001", "--out", str(out)])
