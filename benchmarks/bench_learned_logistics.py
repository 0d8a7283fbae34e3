"""The learned logistics role on the paper's floor (issue 42 item 6): target policies x logistics
roles on the pymunk floor of the built-in case, scripted navigator, paired by seed against Eq.
9 with the paper's c7.

    PYTHONPATH=. python benchmarks/bench_learned_logistics.py --seeds 200-239 --out runs/ll \\
        --runs "priority:never,models/stage2_evaluator.zip:learned=models/logistics_learned.json"
    PYTHONPATH=. python benchmarks/bench_learned_logistics.py --out runs/ll --table

A run is ``EVALUATOR:ROLE``: an evaluator spec (``agents.specs``; a spec may hold ``:``, the
role is after the last one) and a ``--logistics`` spec of the commands
(``cmdp_pymunk.logistics.from_spec``: never, crane-idle, ...), where the ``:`` of a spec is
written ``=`` (``reorder=0.5``, ``learned=PATH``) and ``reorder`` alone is ``reorder:0.5`` (the
names of the first runs). ``model`` is the evaluator's own lift head (a stage-2 model that
decides logistics too, ``agents.lift``; e.g. ``models/stage2_high_level.zip:model``, the one
SB3 model for both decisions), refused for an evaluator without one. Each run's floors go to
``<out>/<run>.csv`` once the run is whole (a stopped benchmark leaves the runs it finished, and
skips them when started again). ``--table`` prints every run in ``--out`` against
``priority:never`` (paired: mean difference with its 95 % interval, ratio of the means,
``training.runs.paired``) and against the learned role's run of the same evaluator. One
process; about 5 s a floor on one core.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk import add_version_flag
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import from_spec
from training.cli import seed_list
from training.runs.paired import mean_ci, paired

REFERENCE = "priority:never"
FIELDS = ("seed", "finished", "makespan_s", "crane_waits", "crane_wait_s", "lifts_asked")


MODEL_ROLE = "model"  # the evaluator's own lift head


def logistics_spec(role: str) -> str:
    """A run's role as a ``--logistics`` spec: ``=`` for ``:`` (a run splits at its last
    ``:``), ``reorder`` alone for ``reorder:0.5`` (the first runs' name), ``model`` as
    ``case`` (the commands then give the floor the evaluator's lift head)."""
    if role == MODEL_ROLE:
        return "case"
    return "reorder:0.5" if role == "reorder" else role.replace("=", ":", 1)


def role_from_spec(role: str, evaluator: str | None = None):
    """The role a run names (``logistics.from_spec``, which checks it naming the fix); for
    ``model``, the lift head of ``evaluator`` (a ValueError with the fix if it has none)."""
    if role != MODEL_ROLE:
        return from_spec(logistics_spec(role), option="role")
    from agents.candidates import logistics_of
    from agents.specs import evaluator_from_spec

    head = logistics_of(evaluator_from_spec(evaluator)) if evaluator else None
    if head is None:
        raise ValueError(f"role 'model': {evaluator!r} has no lift head; fix: a stage-2 model "
                         "written with a lift head (distill student-model --lift), e.g. "
                         "models/stage2_high_level.zip:model, or name a role (never, "
                         "learned=PATH, ...)")
    return head


def split_run(run: str) -> tuple[str, str]:
    evaluator, sep, role = run.rpartition(":")
    if not sep or not evaluator:
        raise ValueError(f"run {run!r}; fix: EVALUATOR:ROLE, e.g. priority:never")
    return evaluator, role


def file_of(out: Path, run: str) -> Path:
    return out / (run.replace("/", "_").replace(":", "__") + ".csv")


def play_run(case, run: str, seeds: list[int], floor: str = "pymunk") -> list[dict]:
    """Every seed of one run on the pymunk floor (or the event floor, ``floor="event"``, with
    the case's calibration): rows of ``FIELDS``."""
    from agents.specs import evaluator_from_spec, make_navigator
    from cmdp_pymunk.eventfloor import calibration_for
    from cmdp_pymunk.rollout import run_episode
    from training.runs.runner import make_engine

    evaluator, role = split_run(run)
    engine = make_engine(case, evaluator_from_spec(evaluator), "scripted", fidelity=floor,
                         calibration=calibration_for(case) if floor == "event" else None,
                         logistics=logistics_spec(role))
    navigator = make_navigator("scripted", engine, False)
    rows = []
    for seed in seeds:
        episode = run_episode(engine, navigator, seed, 3600.0, progress=False)
        crews = engine.site.crews
        lifts = lifts_asked(engine.log.events)
        rows.append({"seed": seed, "finished": engine.site.done,
                     "makespan_s": episode.makespan_s,
                     "crane_waits": sum(c.stats.crane_waits for c in crews),
                     "crane_wait_s": sum(c.stats.crane_wait_steps for c in crews),
                     "lifts_asked": lifts})
        print(f"{run} seed {seed}: {episode.makespan_s} ({episode.wall_s:.1f} s)", flush=True)
    return rows


def lifts_asked(log_events) -> int:
    """Material lifts asked for, early or at an empty storage (c7's, each also a crane wait)."""
    return sum(e.kind == "crane_request" and e.detail == "material" for e in log_events)


def rows_csv(rows: list[dict]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def read_rows(path: Path) -> list[dict]:
    with path.open() as f:
        return [{"seed": int(r["seed"]), "finished": r["finished"] == "True",
                 "makespan_s": float(r["makespan_s"]) if r["makespan_s"] else None,
                 "crane_waits": float(r["crane_waits"]),
                 # the first runs' header named the same count lifts_asked_early
                 "lifts_asked": float(r.get("lifts_asked", r.get("lifts_asked_early")))}
                for r in csv.DictReader(f)]


def table(out: Path) -> str:
    """Every run in ``out`` against ``priority:never``, paired on the seeds both finished."""
    runs = {p.stem.replace("__", ":").replace("models_", "models/"): read_rows(p)
            for p in sorted(out.glob("*.csv"))}
    ref = runs.get(REFERENCE)
    if ref is None:
        raise FileNotFoundError(f"{out}: no {REFERENCE} run; fix: run it first")
    lines = ["| run (target policy : logistics) | finished | makespan (s) | vs Eq. 9 with c7, "
             "paired (s) | ratio | lifts asked | crane waits (c7) |",
             "|---|---|---|---|---|---|---|"]
    for run, rows in runs.items():
        mean, _, ci = mean_ci([r["makespan_s"] for r in rows if r["finished"]])
        vs = paired(rows, ref)
        diff = "-" if run == REFERENCE else f"{vs['diff_mean_s']:+,.0f} ± {vs['diff_ci95_s']:,.0f}"
        ratio = "-" if run == REFERENCE else f"{vs['ratio']:.3f}"
        lifts, _, _ = mean_ci([r["lifts_asked"] for r in rows])
        waits, _, _ = mean_ci([r["crane_waits"] for r in rows])
        lines.append(f"| {run} | {sum(r['finished'] for r in rows)}/{len(rows)} | {mean:,.0f} ± "
                     f"{ci:,.0f} | {diff} | {ratio} | {lifts:.1f} | {waits:.1f} |")
    learned = {split_run(r)[0]: r for r in runs if split_run(r)[1].startswith("learned")}
    lines.append("")
    for run, rows in runs.items():
        evaluator, role = split_run(run)
        if evaluator in learned and run != learned[evaluator]:
            vs = paired(runs[learned[evaluator]], rows)
            lines.append(f"- {learned[evaluator]} against {run}: {vs['diff_mean_s']:+,.0f} ± "
                         f"{vs['diff_ci95_s']:,.0f} s")
    return "\n".join(lines)


@dataclass
class Args:
    seeds: list[int]
    runs: list[str]
    out: Path
    table: bool
    floor: str = "pymunk"


def parse(argv) -> Args:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("--seeds", default="200-239", help="seeds, e.g. 200-239 (default)")
    p.add_argument("--runs", default=REFERENCE, help="comma-separated EVALUATOR:ROLE")
    p.add_argument("--out", type=Path, required=True, help="folder of the runs' CSVs")
    p.add_argument("--table", action="store_true", help="print the table of --out and stop")
    p.add_argument("--floor", choices=("pymunk", "event"), default="pymunk",
                   help="the paper's floor (default) or the event floor")
    a = p.parse_args(argv)
    runs = [r for r in a.runs.split(",") if r]
    for run in runs:  # bad input fails here, before any floor
        try:
            evaluator, role = split_run(run)
            role_from_spec(role, evaluator)
        except ValueError as err:
            p.error(f"--runs {run!r}: {err}")
    return Args(seed_list(a.seeds), runs, a.out, a.table, a.floor)


def main(argv=None) -> int:
    args = parse(sys.argv[1:] if argv is None else argv)
    if args.table:
        print(table(args.out))
        return 0
    case = cmdp_pymunk.load_case(None)
    for run in args.runs:
        path = file_of(args.out, run)
        if path.exists():
            print(f"{run}: {path} exists, skipped")
            continue
        start = time.process_time()
        rows = play_run(case, run, args.seeds, args.floor)
        write_atomic(path, rows_csv(rows))
        print(f"{run}: {len(rows)} floors in {time.process_time() - start:.0f} s CPU -> {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
