"""Where episodes run (training/runs/runner.py): the local backend gives the same results in the
same order with 1 or 2 workers, a dead worker's jobs run again or are reported, the default
path never imports Ray, and ``cmdp-evaluate`` streams its episodes and resumes. The Ray
backend's own tests are in test_ray.py."""

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from test_interrupt import default_sigint

import cmdp_pymunk
from training.commands import evaluate_strategies as evaluate
from training.runs.backends import WorkerLost, Workers, open_backend

ROOT = Path(__file__).resolve().parents[1]
TINY = str(cmdp_pymunk.TINY_CASE)
QUICK = ["--case", TINY, "--strategies", "priority,nearest", "--cpsat-s", "2",
         "--no-progress", "--no-figures"]


def _square(runner, k: int) -> int:
    return k * k


def die_once(runner, marker: str, k: int, kill: int) -> int:
    """Job k == kill kills its own worker process the first time (``marker`` remembers)."""
    if k == kill and not os.path.exists(marker):
        Path(marker).touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return k


def die_always(runner, k: int, kill: int) -> int:
    if k == kill:
        os.kill(os.getpid(), signal.SIGKILL)
    return k


def rows_of(out: Path) -> list[dict]:
    """episodes.csv without the wall times (the only column that differs between runs)."""
    return [{k: v for k, v in r.items() if k != "wall_s"}
            for r in csv.DictReader((out / "episodes.csv").open())]


# The three pool tests below spawn fresh worker processes (a few seconds each on 2 cores) to
# check the pool itself: slow set. The gate keeps the pool's end-to-end checks with real
# episodes (1 and 2 workers: test_episodes_stream_to_a_log_and_a_stopped_run_resumes here,
# test_simulate.py::test_episodes_are_the_same_with_any_number_of_workers).
@pytest.mark.slow
def test_results_come_in_job_order_with_any_number_of_workers():
    jobs = [(k,) for k in range(7)]
    for workers in (1, 2):
        with open_backend(_square, None, workers) as pool:
            assert pool.map(jobs) == [k * k for k in range(7)]
            assert sorted(pool.as_completed(jobs)) == [(k, k * k) for k in range(7)]


@pytest.mark.slow
def test_a_dead_workers_jobs_run_again(tmp_path):
    with Workers(die_once, None, 2, retries=1) as pool:
        assert pool.map([(str(tmp_path / "died"), k, 2) for k in range(5)]) == list(range(5))
    assert (tmp_path / "died").exists()


@pytest.mark.slow
def test_a_job_that_kills_every_worker_is_reported_not_lost():
    got = []
    with pytest.raises(WorkerLost) as err, Workers(die_always, None, 2, retries=1) as pool:
        for _, k in pool.as_completed([(k, 3) for k in range(5)]):
            got.append(k)
    assert err.value.lost == [3]
    assert sorted(got) == [0, 1, 2, 4]  # every other job was handed out first


def ray_is_installed() -> bool:
    import importlib.util

    return importlib.util.find_spec("ray") is not None


@pytest.mark.ray  # also in the Ray venv (make test-ray), where importing it would be possible
@pytest.mark.skipif(not ray_is_installed(), reason="without Ray nothing can import it: the "
                    "check runs where Ray is installed (make test-ray, in CI)")
def test_the_default_path_never_imports_ray(tmp_path):
    """cmdp-evaluate and cmdp-simulate in worker processes, and stage 2's floors in worker
    processes (``cmdp-train stage2`` without --ray), import no Ray."""
    argv = [*QUICK, "--seeds", "0-1", "--workers", "2", "--out", str(tmp_path)]
    simulate = ["--case", TINY, "--episodes", "2", "--workers", "2", "--no-charts",
                "--no-progress", "--out", str(tmp_path / "simulate")]
    code = ("import sys; from training import stage2; "
            "from training.commands import evaluate_strategies as compare, simulate; "
            f"assert compare.main({argv!r}) == 0; "
            f"assert simulate.main({simulate!r}) == 0; "
            f"config = stage2.Stage2Config(case={TINY!r}, n_envs=2, num_cpus=2); "
            "venv = stage2.make_vec_env(config, stage2.training_case(config), 0); "
            "venv.reset(); venv.close(); "
            "assert 'ray' not in sys.modules, 'ray was imported'")
    env = dict(os.environ, PYTHONPATH=str(ROOT), SDL_VIDEODRIVER="dummy")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr


def test_ray_without_ray_installed_is_one_clear_line(tmp_path, capsys):
    try:
        import ray  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("ray is installed here (test_ray.py covers --ray)")
    assert evaluate.main([*QUICK, "--seeds", "0", "--ray", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-evaluate: --ray needs Ray") and "pip install -e '.[ray]'" in err
    assert not (tmp_path / "episodes.jsonl").exists()
    from training.commands import simulate, train

    out = tmp_path / "simulate"
    assert simulate.main(["--case", TINY, "--episodes", "2", "--ray", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-simulate: --ray needs Ray") and not out.exists()
    out = tmp_path / "train"
    assert train.main(["stage2", "--ray", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-train: --ray needs Ray") and "\n" not in err
    assert not out.exists()


def test_episodes_stream_to_a_log_and_a_stopped_run_resumes(tmp_path):
    full, part = tmp_path / "full", tmp_path / "part"
    assert evaluate.main([*QUICK, "--seeds", "0-2", "--workers", "1", "--out", str(full)]) == 0
    log = [json.loads(line) for line in (full / "episodes.jsonl").read_text().splitlines()]
    assert len(log) == 6
    # A run stopped after two episodes, the third cut mid-line (a killed process).
    part.mkdir()
    lines = (full / "episodes.jsonl").read_text().splitlines(keepends=True)
    (part / "episodes.jsonl").write_text("".join(lines[:2]) + lines[2][:20])
    (part / "resume.json").write_bytes((full / "resume.json").read_bytes())
    assert evaluate.main([*QUICK, "--seeds", "0-2", "--workers", "2", "--out", str(part),
                          "--resume"]) == 0
    assert rows_of(part) == rows_of(full)
    kept = [json.loads(line) for line in (part / "episodes.jsonl").read_text().splitlines()]
    assert kept[:2] == log[:2] and len(kept) == 6  # the two kept ones were not run again
    assert json.loads((part / "settings.json").read_text())["episodes_resumed"] == 2


def test_resume_with_other_settings_is_refused(tmp_path, capsys):
    assert evaluate.main([*QUICK, "--seeds", "0", "--workers", "1", "--out", str(tmp_path)]) == 0
    assert evaluate.main([*QUICK, "--seeds", "0", "--workers", "1", "--out", str(tmp_path),
                          "--resume", "--stall-s", "100"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cmdp-evaluate: --resume:") and "(stall_s)" in err, err
    assert evaluate.main([*QUICK, "--seeds", "0", "--out", str(tmp_path / "new"),
                          "--resume"]) == 2


def interrupt_evaluate(argv: list[str], lines: int = 2) -> tuple[int, str]:
    """Run cmdp-evaluate in a child, SIGINT it once ``lines`` episodes are in its log."""
    import time

    out = Path(argv[argv.index("--out") + 1])
    env = dict(os.environ, PYTHONPATH=str(ROOT), SDL_VIDEODRIVER="dummy", PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "training.commands.evaluate_strategies", *argv],
                            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, preexec_fn=default_sigint)
    try:
        log = out / "episodes.jsonl"
        deadline = time.monotonic() + 240
        while not (log.exists() and log.read_text().count("\n") >= lines):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline, "no episode finished in 240 s"
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before the signal: give it more seeds"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    return proc.returncode, err


def assert_complete_outputs_only(out: Path) -> list[dict]:
    """No temporary file, no result file of the unfinished run, a log of whole rows."""
    assert not [p for p in out.rglob("*") if ".tmp" in p.name]
    assert not [n for n in ("episodes.csv", "summary.csv", "summary.md", "settings.json")
                if (out / n).exists()]
    return [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]


@pytest.mark.slow
def test_ctrl_c_keeps_the_finished_episodes_and_resume_finishes(tmp_path):
    out = tmp_path / "run"
    # 20 seeds x 2 strategies: the signal comes once 2 episodes are logged, the other 38
    # (about 0.2 s each on two workers) still to run; the resume runs what is left
    argv = [*QUICK, "--seeds", "0-19", "--workers", "2", "--out", str(out)]
    code, err = interrupt_evaluate(argv)
    assert code == 130, err
    # (Python's resource tracker may add a warning about the killed workers' semaphores.)
    assert "Traceback" not in err and "\ncmdp-evaluate: interrupted; " in err, err
    kept = assert_complete_outputs_only(out)
    assert 2 <= len(kept) < 40
    assert evaluate.main([*argv, "--resume"]) in (0, 1)
    assert len(rows_of(out)) == 40
