"""Golden regression: ``cmdp-simulate`` on the built-in case writes the same schedules as the
recorded ones (sha256 of each seed's ``events.csv`` and its makespan, in
``tests/data/golden_simulate.json``).

A refactoring must leave these untouched. A change that alters schedules on purpose (a fix, a
new rule) regenerates them in the same commit and says why in the commit message:

    PYTHONPATH=. python tests/test_golden.py --update --reason "why the schedules changed"

The fast test replays seed 0 alone; the slow one all recorded seeds in one ``--episodes`` run
(the env and navigator reused across episodes, as in ``cmdp-simulate --episodes 10``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parent / "data" / "golden_simulate.json"
SEEDS = range(10)


def simulate_seeds(first: int, episodes: int, out: Path) -> dict[str, dict]:
    """seed -> {"events_sha256", "makespan_s"} of one ``cmdp-simulate`` run."""
    from training.commands import simulate

    argv = ["--seed", str(first), "--episodes", str(episodes), "--out", str(out),
            "--no-charts", "--no-progress"]
    code = simulate.main(argv)
    assert code == 0, f"cmdp-simulate {' '.join(argv)} exited with {code}"
    runs = {}
    for seed in range(first, first + episodes):
        folder = out if episodes == 1 else out / f"seed-{seed}"
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
        runs[str(seed)] = {
            "events_sha256": hashlib.sha256((folder / "events.csv").read_bytes()).hexdigest(),
            "makespan_s": summary["makespan_s"]}
    return runs


def golden() -> dict:
    return json.loads(GOLDEN.read_text(encoding="utf-8"))


def test_seed_0_matches_the_golden_schedule(tmp_path):
    assert simulate_seeds(0, 1, tmp_path)["0"] == golden()["seeds"]["0"], \
        f"seed 0 changed; if on purpose, regenerate: {golden()['regenerate']}"


@pytest.mark.slow
def test_every_recorded_seed_matches_the_golden_schedules(tmp_path):
    recorded = golden()["seeds"]
    assert simulate_seeds(0, len(recorded), tmp_path) == recorded, \
        f"schedules changed; if on purpose, regenerate: {golden()['regenerate']}"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description="check or regenerate the golden schedules")
    p.add_argument("--update", action="store_true", help="rewrite tests/data/golden_simulate.json")
    p.add_argument("--reason", default="", help="why the schedules changed (kept in the file)")
    a = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        runs = simulate_seeds(SEEDS.start, len(SEEDS), Path(tmp))
    if not a.update:
        same = runs == golden()["seeds"]
        print("golden schedules: " + ("unchanged" if same else "CHANGED"))
        return 0 if same else 1
    from cmdp_pymunk.events import write_atomic
    from cmdp_pymunk.report import versions

    data = {"comment": "cmdp-simulate on the built-in case (priority evaluator, scripted "
                       "navigator), seeds 0-9 in one --episodes run; checked by "
                       "tests/test_golden.py",
            "regenerate": 'PYTHONPATH=. python tests/test_golden.py --update --reason "..."',
            "reason": a.reason, "commit": versions()["commit"], "seeds": runs}
    write_atomic(GOLDEN, json.dumps(data, indent=2) + "\n")
    print(f"wrote {GOLDEN}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
