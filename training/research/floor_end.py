"""How a floor ends: from the last task of one type (the reinforcing crews' R by default) to the
floor's end, and the tasks of the type after it (F) that were left for that time.

    python -m training.research.floor_end --strategy student:models/api_student_r4.json \
        --seeds 140-159 [--last R] [--then F] [--case FILE] [--out report.json]

The last R task's own F successor cannot start before it ends, so about one F task's duration
of the time after it is unavoidable; the rest is formwork left behind (issue 32: research-log.md,
"The student's ceiling"). Each seed's floor is played on the pymunk floor with the scripted
navigator; the means over the seeds are printed (and written with ``--out``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

import cmdp_pymunk
from agents.specs import evaluator_from_spec
from cmdp_pymunk.events import write_atomic
from training.cli import OneLineParser, seed_list
from training.runs.runner import EpisodeRunner


def floor_end(tasks, makespan_s: float, last: str = "R", then: str = "F") -> dict:
    """For one finished floor (``tasks`` with ``type``, ``started_s`` and ``ended_s``): the
    seconds from the last ``last``-type task's end to ``makespan_s``, how many ``then``-type
    tasks started at or after that moment and how many were running at it, and the duration
    of the ``then`` task that ended last."""
    last_end = max(t.ended_s for t in tasks if t.type == last)
    following = [t for t in tasks if t.type == then]
    final = max(following, key=lambda t: t.ended_s)
    return {"makespan_s": makespan_s, "after_last_s": makespan_s - last_end,
            "started_after": sum(t.started_s >= last_end for t in following),
            "running_at_it": sum(t.started_s < last_end < t.ended_s for t in following),
            "last_then_duration_s": final.ended_s - final.started_s}


def floor_row(runner, strategy: str, seed: int, last: str, then: str) -> dict:
    """One seed's floor under ``strategy`` (the scripted navigator), as ``floor_end``'s row;
    ValueError if the floor did not finish."""

    engine, _ = runner.play(evaluator_from_spec(strategy), "scripted", seed)
    if engine.makespan_s is None:
        raise ValueError(f"seed {seed}: the floor under {strategy} did not finish")
    return {"seed": seed, **floor_end(engine.site.tasks, engine.makespan_s, last, then)}


def main(argv: list[str] | None = None) -> int:

    p = OneLineParser(prog="python -m training.research.floor_end",
                      description=__doc__.split("\n")[0])
    p.add_argument("--strategy", default="priority", help="an evaluator spec (default Eq. 9)")
    p.add_argument("--seeds", type=seed_list, default=seed_list("140-159"))
    p.add_argument("--last", default="R", help="the task type whose last end is the mark")
    p.add_argument("--then", default="F", help="the task type after it")
    p.add_argument("--case", default=None, help="case file (default: built-in)")
    p.add_argument("--out", default="", help="also write the rows and means (JSON) here")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)

    try:
        case = cmdp_pymunk.load_case(args.case)
        evaluator_from_spec(args.strategy)
        types = set(case.task_types)
        unknown = [t for t in (args.last, args.then) if t not in types]
        if unknown:
            raise ValueError(f"task type(s) {unknown} are not the case's "
                             f"({', '.join(sorted(types))}); fix: --last and --then")
    except ValueError as err:
        print(f"floor_end: {err}", file=sys.stderr)
        return 2
    runner = EpisodeRunner(case)
    try:
        rows = [floor_row(runner, args.strategy, s, args.last, args.then) for s in args.seeds]
    except ValueError as err:
        print(f"floor_end: {err}", file=sys.stderr)
        return 2
    means = {k: float(np.mean([r[k] for r in rows])) for k in rows[0] if k != "seed"}
    print(f"floor_end: {args.strategy}, {len(rows)} floors: makespan {means['makespan_s']:,.0f} "
          f"s; from the last {args.last} task's end to the floor's end "
          f"{means['after_last_s']:,.0f} s; {args.then} tasks started after it "
          f"{means['started_after']:.2f}, running at it {means['running_at_it']:.2f}; the last "
          f"{args.then} task's duration {means['last_then_duration_s']:,.0f} s")
    if args.out:

        write_atomic(Path(args.out), json.dumps({"strategy": args.strategy, "rows": rows,
                                                 "means": means}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
