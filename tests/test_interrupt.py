"""Ctrl-C is never lost (cmdp_pymunk/interrupt.py): a SIGINT that lands inside one of pymunk's
cffi callbacks still stops the run, and the command-line tools stop with one line, exit 130,
no traceback and no half-written file."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import tiny_dict

import cmdp_pymunk
from cmdp_pymunk.cases.load import case_from_dict
from cmdp_pymunk.interrupt import sigint_guard

ROOT = Path(__file__).resolve().parents[1]
TINY = str(cmdp_pymunk.TINY_CASE)


def world_with_a_callback_that_gets_sigint():
    """A tiny world whose first crew's velocity_func receives a SIGINT on its first call."""
    env = cmdp_pymunk.parallel_env(case=case_from_dict(tiny_dict()), seed=0)
    env.reset(seed=0)
    world = env.engine.world
    body = world.bodies[0]
    inner = body.velocity_func
    fired = []

    def velocity_func(b, gravity, damping, dt):
        if not fired:
            fired.append(True)
            signal.raise_signal(signal.SIGINT)  # arrives inside pymunk's C step
        inner(b, gravity, damping, dt)

    body.velocity_func = velocity_func
    world.desired[0][0] = 1.0  # someone wants to move: the step runs pymunk
    return world, fired


@pytest.fixture(autouse=True)
def python_sigint_handler():
    """Each test starts from Python's own SIGINT handler, as under a terminal. A run started
    in the background (``cmd &`` in a script, some CI runners) inherits SIGINT ignored, and
    Python then keeps it ignored: these tests would see nothing arrive."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def default_sigint() -> None:
    """In a child before exec: SIGINT back to the default, so that Python installs its handler
    even where this test run inherited SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.fixture
def unraisable(monkeypatch):
    """What cffi reports as "Exception ignored from cffi callback" (sys.unraisablehook)."""
    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.exc_type))
    return seen


def test_without_the_guard_cffi_swallows_the_interrupt(unraisable):
    """The bug the guard fixes: Python's own handler raises inside the callback, cffi
    reports it as ignored and the step returns as if nothing happened."""
    world, fired = world_with_a_callback_that_gets_sigint()
    world.step(1.0, 2)
    assert fired and unraisable == [KeyboardInterrupt]


def test_a_sigint_inside_a_pymunk_callback_is_raised_after_the_step(unraisable):
    world, fired = world_with_a_callback_that_gets_sigint()
    with pytest.raises(KeyboardInterrupt), sigint_guard():
        world.step(1.0, 2)
    assert fired and unraisable == []
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back


def test_the_guard_leaves_an_ignored_sigint_ignored():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with sigint_guard():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            signal.raise_signal(signal.SIGINT)  # a background job: nothing happens
    finally:
        signal.signal(signal.SIGINT, previous)


def run_and_interrupt(module: str, argv: list[str], after_s: float,
                      wait_for: str = "") -> tuple[int, str]:
    """Start ``python -m``-like the command ``module``'s ``entry_point``; wait for a stdout
    line holding ``wait_for`` (first line if empty) plus ``after_s`` seconds (a negative value:
    that long after the start, without waiting for a line); send SIGINT; return (status,
    stderr)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), SDL_VIDEODRIVER="dummy",
               PYGAME_HIDE_SUPPORT_PROMPT="1", PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-c", f"from {module} import entry_point; "
                             "entry_point()", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
                            preexec_fn=default_sigint)
    try:
        if after_s < 0:
            time.sleep(-after_s)
        else:
            while wait_for not in (line := proc.stdout.readline()):
                assert line, f"the command ended before printing {wait_for!r}"
            time.sleep(after_s)
        assert proc.poll() is None, "the command ended before the signal: make it longer"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    return proc.returncode, err


def one_line(err: str, prog: str) -> str:
    """The command's only line on stderr, with no traceback anywhere."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert len(lines) == 1 and lines[0].startswith(f"{prog}: interrupted"), err
    return lines[0]


def assert_no_half_written_files(out: Path) -> None:
    """No temporary file, and every seed folder holds all its files."""
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    for folder in out.glob("seed-*"):
        names = {p.name for p in folder.iterdir()}
        assert {"summary.json", "events.csv", "gantt_agents.png", "gantt_tasks.png",
                "trajectories.png"} <= names, folder
        json.loads((folder / "summary.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("moment_s", [-0.3, 0.0, 0.4, 1.1, 1.9, 2.8, 3.9])
def test_simulate_stops_at_every_moment_with_one_line_and_exit_130(moment_s, tmp_path):
    """Moments before the banner (imports), in an episode, between episodes and while a
    seed's charts are written (about half of a tiny episode's wall time)."""
    out = tmp_path / "out"
    code, err = run_and_interrupt("training.commands.simulate", ["--case", TINY, "--episodes", "30",
                                                        "--no-progress", "--out", str(out)],
                                  moment_s)
    assert code == 130, err
    one_line(err, "cmdp-simulate")
    if out.exists():
        assert_no_half_written_files(out)


def test_simulate_stops_in_an_episode_of_the_builtin_case(tmp_path):
    """The case the issue saw lose 2 Ctrl-C in 10 (inside pymunk's velocity callback)."""
    out = tmp_path / "out"
    code, err = run_and_interrupt("training.commands.simulate",
                                  ["--no-charts", "--no-progress", "--out", str(out)], 1.0)
    assert code == 130, err
    line = one_line(err, "cmdp-simulate")
    assert line.startswith("cmdp-simulate: interrupted in seed 0 at t = "), line
    assert "no episode finished, nothing kept" in line
    assert sorted(p.name for p in out.iterdir()) == ["case.json"]


@pytest.mark.slow  # slow: the built-in floor's Ctrl-C test stays in the gate
def test_simulate_stops_inside_a_lookahead_branch(tmp_path):
    """Ctrl-C while the lookahead runs a branch of the built-in floor: one line, exit 130,
    no half-written outputs."""
    out = tmp_path / "out"
    code, err = run_and_interrupt("training.commands.simulate",
                                  ["--evaluator", "lookahead:candidates=3+futures=1",
                                   "--no-charts", "--no-progress", "--out", str(out)], 2.5)
    assert code == 130, err
    line = one_line(err, "cmdp-simulate")
    assert line.startswith("cmdp-simulate: interrupted in seed 0 at t = "), line
    assert sorted(p.name for p in out.iterdir()) == ["case.json"]


TRAIN = ["stage1", "--set", f"case='{TINY}'", "--set", "n_envs=2", "--set", "num_cpus=2",
         "--set", "n_steps=128", "--set", "batch_size=256", "--set", "n_epochs=1",
         "--set", "bc_epochs=1", "--set", "episode_time_s=200", "--no-progress"]


@pytest.mark.slow
def test_train_stops_during_behaviour_cloning_and_says_nothing_was_saved(tmp_path):
    run = tmp_path / "run"
    code, err = run_and_interrupt("training.commands.train", [*TRAIN, "--out", str(run), "--set",
                                                      "bc_samples=10000000"],
                                  1.0, wait_for="behaviour cloning: collecting")
    assert code == 130, err
    line = one_line(err, "cmdp-train")
    assert "during behaviour cloning" in line and "nothing could be saved yet" in line
    assert sorted(p.name for p in run.iterdir()) == ["case.json", "config.json"]


@pytest.mark.slow
def test_train_stops_during_ppo_with_a_checkpoint_to_resume_from(tmp_path):
    from stable_baselines3 import PPO

    run = tmp_path / "run"
    code, err = run_and_interrupt("training.commands.train", [*TRAIN, "--out", str(run), "--set",
                                                      "bc_samples=0", "--set",
                                                      "total_steps=100000000"],
                                  2.0, wait_for="PPO:")
    assert code == 130, err
    saved = run / "checkpoints" / "interrupted.zip"
    assert f"saved {saved}; resume with --resume {saved}" in one_line(err, "cmdp-train")
    assert PPO.load(str(saved), device="cpu").num_timesteps > 0
    assert not [p for p in run.rglob("*") if ".tmp" in p.name]


@pytest.mark.slow
def test_train_stage2_stops_during_ppo_with_a_checkpoint_to_resume_from(tmp_path):
    run = tmp_path / "run"
    code, err = run_and_interrupt("training.commands.train", [
        "stage2", "--out", str(run), "--no-progress", "--set", "bc_episodes=0",
        "--set", "num_cpus=2", "--set", "n_steps=16", "--set", "batch_size=32",
        "--set", "eval_seeds=[2000]", "--set", "total_steps=100000000"], 2.0, wait_for="PPO:")
    assert code == 130, err
    saved = run / "checkpoints" / "interrupted.zip"
    assert f"saved {saved}; resume with --resume {saved}" in one_line(err, "cmdp-train")
    assert saved.is_file()
    assert not [p for p in run.rglob("*") if ".tmp" in p.name]
