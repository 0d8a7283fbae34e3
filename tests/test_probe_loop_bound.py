"""benchmarks/probe_loop_bound.py: the passes it makes free feed nothing of the dynamics (the
probe refuses otherwise), and each is put back after its block."""

import importlib.util
from pathlib import Path

from cmdp_pymunk import engine, metrics, reward

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "probe_loop_bound.py"
spec = importlib.util.spec_from_file_location("probe_loop_bound", PATH)
probe = importlib.util.module_from_spec(spec)
spec.loader.exec_module(probe)


def test_one_seed_plays_alike_with_the_bookkeeping_free_and_everything_is_put_back(capsys):
    kept = (metrics.Counters.count, engine.Advance.add, engine.Engine._log_activities,
            reward.evaluation_reward_terms)
    assert probe.main(["--seeds", "3", "--rounds", "1"]) == 0  # the makespans matched
    out = capsys.readouterr().out
    assert "bookkeeping free" in out and "at most" in out
    assert (metrics.Counters.count, engine.Advance.add, engine.Engine._log_activities,
            reward.evaluation_reward_terms) == kept


def test_a_pass_that_feeds_the_dynamics_is_refused(monkeypatch):
    # the stall guard's mark moves the next event's time: made "free" it would change floors
    monkeypatch.setattr(probe, "_FREE", (*probe._FREE,
                                         (engine.Engine, "task_progress", lambda self: (0, 0.0))))
    try:
        probe.main(["--seeds", "3", "--rounds", "1"])
    except SystemExit as stop:
        assert "makespans differ" in str(stop)
    else:
        raise AssertionError("a pass feeding the dynamics was not refused")


def test_every_span_is_put_down_to_one_cause_and_the_motion_is_left_as_it_was():
    import cmdp_pymunk
    from cmdp_pymunk.eventfloor import EventFloor

    floor = EventFloor(cmdp_pymunk.load_case(None), evaluator="priority", stall_s=3600.0)
    causes = probe.event_causes(floor, [3])
    assert set(causes) <= {"P_cons' next change", "a walk arrives",
                           "a row due in the next second", "the rest"}
    assert sum(causes.values()) == floor.spans_run  # one cause a span (seed 3's spans)
    assert causes["P_cons' next change"] > 0 and causes["a walk arrives"] > 0
    assert "span_s" not in vars(floor.motion)  # the class's own again
