"""N event floors of ``cmdp-simulate`` end to end, by phase, against another checkout's.

    git archive COMMIT | tar -x -C /tmp/before           # the code to compare against
    python benchmarks/bench_simulate_many.py [--episodes 1000] [--workers 2] [--rounds 1]
                                             [--base /tmp/before] [--out /tmp/bench_many]

Runs ``cmdp-simulate --fidelity event --episodes N --workers W --no-seed-charts
--no-progress`` (issue 43's run; the built-in case) in a fresh Python process per run, as a
user does, and prints:

- **wall**: the process from start to exit (interpreter start and imports included);
- **start-up**: until the first seed's result is in this process (imports, the case, its
  bound, the engine this process keeps, the workers started, their imports, the first floor);
- **play**: from there until the last seed's files are written: this process waiting for the
  workers' results and writing each seed's files; **outputs** is the part of the whole run
  spent writing those files (``write_outputs``, this process's wall and CPU);
- **end**: after the last seed (``makespans.csv``/``.json``, the histogram, the S-curve);
- **CPU**: this process's and its workers' (the children's), seconds.

With ``--base`` each round runs the other checkout first, then this one, so both meet about
the same load, and the ratios (base / this) close the table. The machine's load average is
printed beside each run: on a shared machine a timing under load says more about the load than
the code. Output folders are deleted after each run (pass ``--keep`` to keep them, e.g. to
``diff -r`` the two).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import cmdp_pymunk

HERE = Path(__file__).resolve().parents[1]
PHASES = ("wall_s", "startup_s", "play_s", "outputs_s", "outputs_cpu_s", "end_s", "main_cpu_s",
          "workers_cpu_s")

# Run in the child, with the checkout under test first on sys.path: times the phases by
# wrapping ``play_seeds`` and ``write_outputs`` (module globals, looked up at each call) and
# the backends' ``imap`` (results in job order: the first one marks the end of the start-up).
CHILD = r"""
import json, resource, sys, time
t0 = time.perf_counter()
from training.runs import base, simulation
from training.commands import simulate
marks, out = {}, {"outputs_s": 0.0, "outputs_cpu_s": 0.0}
play_seeds, write_outputs, imap = simulation.play_seeds, simulation.write_outputs, base.Backend.imap
def timed_play(*a, **k):
    try:
        return play_seeds(*a, **k)
    finally:
        marks["end"] = time.perf_counter()
def timed_imap(*a, **k):
    for result in imap(*a, **k):
        marks.setdefault("first", time.perf_counter())
        yield result
base.Backend.imap = timed_imap
def timed_write(*a, **k):
    w, c = time.perf_counter(), time.process_time()
    try:
        return write_outputs(*a, **k)
    finally:
        out["outputs_s"] += time.perf_counter() - w
        out["outputs_cpu_s"] += time.process_time() - c
simulation.play_seeds, simulation.write_outputs = timed_play, timed_write
code = simulate.main(sys.argv[2:])
t1 = time.perf_counter()
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
out.update(code=code, play_s=marks["end"] - marks["first"],
           end_s=t1 - marks["end"], main_cpu_s=me.ru_utime + me.ru_stime,
           workers_cpu_s=kids.ru_utime + kids.ru_stime)
with open(sys.argv[1], "w") as f:
    json.dump(out, f)
"""


def run_once(tree: Path, args, out: Path) -> dict:
    """One ``cmdp-simulate`` run on ``tree``'s code in a new process: its phases."""
    shutil.rmtree(out, ignore_errors=True)
    stats = out.with_suffix(".json")
    env = dict(os.environ, PYTHONPATH=str(tree), SDL_VIDEODRIVER="dummy",
               SDL_AUDIODRIVER="dummy")
    command = [sys.executable, "-c", CHILD, str(stats), "--fidelity", "event", "--episodes",
               str(args.episodes), "--workers", str(args.workers), "--no-seed-charts",
               "--no-progress", "--out", str(out)]
    load = os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run(command, cwd=tree, env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0 or not stats.is_file():
        raise SystemExit(f"{tree}: cmdp-simulate failed (exit {done.returncode}):\n"
                         f"{done.stderr[-2000:]}")
    phases = json.loads(stats.read_text())
    phases["wall_s"], phases["load"] = wall, load
    # the child's clock starts after the interpreter: start-up counts from the process start
    phases["startup_s"] = wall - phases["play_s"] - phases["end_s"]
    if not args.keep:
        shutil.rmtree(out, ignore_errors=True)
    stats.unlink()
    return phases


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--rounds", type=int, default=1)
    p.add_argument("--base", type=Path, default=None,
                   help="the root of another checkout, run before this one in each round")
    p.add_argument("--out", type=Path, default=Path("/tmp/bench_simulate_many"))
    p.add_argument("--keep", action="store_true", help="keep the output folders")
    args = p.parse_args(argv)
    trees = {"this": HERE}
    if args.base is not None:
        if not (args.base / "training" / "commands" / "simulate.py").is_file():
            raise SystemExit(f"--base {args.base}: no training/commands/simulate.py there; fix: "
                             "give the root of a checkout (git archive COMMIT | tar -x -C DIR)")
        trees = {"base": args.base.resolve(), "this": HERE}
    runs: dict[str, list[dict]] = {name: [] for name in trees}
    print(f"cmdp-simulate --fidelity event --episodes {args.episodes} --workers {args.workers} "
          f"--no-seed-charts --no-progress ({os.cpu_count()} CPUs)")
    header = "run          load  " + "  ".join(f"{k[:-2]:>11s}" for k in PHASES)
    print(header)
    for r in range(args.rounds):
        for name, tree in trees.items():
            phases = run_once(tree, args, args.out / f"{name}-{r}")
            runs[name].append(phases)
            print(f"{name:5s} round {r}  {phases['load']:4.1f}  "
                  + "  ".join(f"{phases[k]:11.2f}" for k in PHASES), flush=True)
    medians = {name: {k: statistics.median(p[k] for p in rs) for k in PHASES}
               for name, rs in runs.items()}
    for name, m in medians.items():
        print(f"{name:5s} median       " + "  ".join(f"{m[k]:11.2f}" for k in PHASES))
    if "base" in medians:
        print("base / this        " + "  ".join(
            f"{medians['base'][k] / medians['this'][k]:10.2f}x" if medians["this"][k] > 0
            else f"{'-':>11s}" for k in PHASES))
    return 0


if __name__ == "__main__":
    sys.exit(main())
