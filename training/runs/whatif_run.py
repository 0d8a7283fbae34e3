"""The what-if behind ``cmdp-evaluate --cases/--variant`` (``training.whatif`` holds its
rows, summary and table): every case and variant x strategy x low level x seed on the same
seeds, each variant on its base's floor. Apart from ``strategies`` (the run of strategies on
one case, whose arguments, checks and tables it shares) because it is a run of its own: its
entries, its log, its files.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import from_spec
from cmdp_pymunk.report import versions
from training.fidelity import resolve_floor
from training.runs.backends import WorkerLost, open_backend
from training.runs.paired import time_use_summary, time_use_table
from training.runs.runner import ROW_FIELDS, SEED_BOUND_FIELDS
from training.runs.strategies import (
    LOG,
    BadSetting,
    EvaluateArgs,
    check_specs,
    logistics_label,
    write_tables,
)
from training.whatif import MONEY_FIELDS, cost_note


def whatif_entries(args: EvaluateArgs) -> list:
    """The cases and variants of a what-if (``training.whatif.Entry``), the base first, each
    validated and with its floor, before anything runs; ValueError (a ``CaseError`` for a bad
    case or variant) naming the option, the entry and the fix. A variant runs on its base's
    floor: on the event floor, with the base case's calibration (crew-type numbers fitted on
    the base floor; the output says so)."""
    from cmdp_pymunk.cases.levers import make_variant, parse_variant_option
    from training.whatif import Entry

    paths = list(args.cases) or [None]
    entries: list[Entry] = []
    for i, path in enumerate(paths):
        case = cmdp_pymunk.load_case(path)
        floor = resolve_floor(case, path, args.fidelity, args.calibration if i == 0 else None,
                              {"--navigators": args.navigators})
        name = case.case.name
        if any(e.name == name for e in entries):
            name = Path(path).stem if path is not None else "built-in"
        entries.append(Entry(name, "", case, str(path) if path else "built-in", floor))
    base = entries[0]
    for text in args.variants:
        name, changes = parse_variant_option(text)
        if any(e.name == name for e in entries):
            raise ValueError(f"--variant {text!r}: the name {name!r} is taken; fix: give each "
                             "case and variant its own name")
        variant = make_variant(base.case, changes, name, source=f"--variant {name}")
        entries.append(Entry(name, variant.label, variant.case, f"--variant {text}",
                             base.floor))
    return entries


def compare_whatif(args: EvaluateArgs) -> int:
    """The what-if (``training.whatif``): every case and variant x strategy x low level x
    seed; writes episodes.jsonl, episodes.csv, whatif.md, whatif.csv, whatif.json,
    time_use.csv, variants/NAME.toml (each variant as a case file) and settings.json."""
    from tqdm import tqdm

    from cmdp_pymunk import interrupt
    from cmdp_pymunk.cases.levers import variant_toml
    from training.whatif import PAIRING_NOTE, whatif_job, whatif_summary, whatif_table

    try:
        entries = whatif_entries(args)
        for e in entries:
            check_specs(e.case, args.strategies, args.navigators, args.deterministic)
            from_spec(args.logistics, case=e.case)
    except ValueError as err:  # CaseError is a ValueError
        raise BadSetting(str(err)) from None
    args.out.mkdir(parents=True, exist_ok=True)
    tail = (args.stall_s, args.max_time_s, args.deterministic, None)
    labels = [(e, s, n, seed) for e in entries for n in args.navigators
              for s in args.strategies for seed in args.seeds]
    jobs = [(e.name, e.case.model_dump(mode="json"),
             (*tail, *e.floor.runner_args, args.logistics), s, n, seed)
            for e, s, n, seed in labels]
    print(f"cmdp-evaluate: what-if of {len(entries)} cases and variants against "
          f"{entries[0].name!r} on the {entries[0].floor.label()}"
          f"{logistics_label(args.logistics)}: {len(jobs)} episodes "
          f"({len(args.strategies)} strategies x {len(args.navigators)} low level(s) x "
          f"{len(args.seeds)} seeds each)", flush=True)
    note = entries[0].floor.uncalibrated_note(args.case)
    if note:
        print(f"cmdp-evaluate: {note}", file=sys.stderr, flush=True)
    rows: list[dict | None] = [None] * len(jobs)
    start = time.perf_counter()
    bar = tqdm(total=len(jobs), unit="episode", disable=not args.progress, mininterval=1.0,
               desc="cmdp-evaluate")
    try:
        with (args.out / LOG).open("w") as log, \
                open_backend(whatif_job, None, args.workers, args.ray) as pool:
            for i, row in pool.as_completed(jobs):
                e, strategy, navigator, seed = labels[i]
                rows[i] = {"variant": e.name, "strategy": strategy, "navigator": navigator,
                           "seed": seed, "fidelity": e.floor.fidelity, **row}
                log.write(json.dumps(rows[i]) + "\n")
                log.flush()
                bar.update(1)
    except WorkerLost as err:
        print(f"cmdp-evaluate: {err}; the finished episodes are in {args.out / LOG}",
              file=sys.stderr)
        return 1
    finally:
        bar.close()
    wall = time.perf_counter() - start
    summary = whatif_summary(rows, entries)
    notes = [cost_note(entries[0].case)]
    if any(e.changes and e.floor.fidelity == "event" for e in entries):
        notes.append(f"On the {entries[0].floor.label()}, not the pymunk floor; each variant "
                     "runs on its base's calibration (crew-type numbers fitted on the base "
                     "floor).")
    time_use = time_use_summary([{**r, "strategy": f"{r['variant']} / {r['strategy']}"}
                                 for r in rows])
    table = whatif_table(summary, entries, notes)
    if time_use:
        table += "\n" + time_use_table(time_use)
    fields = ["variant", "strategy", "navigator", "seed", *ROW_FIELDS, *SEED_BOUND_FIELDS,
              "fidelity", *MONEY_FIELDS]
    settings = {**asdict(args), "backend": pool.label, "episodes": len(rows),
                "entries": [{"name": e.name, "changes": e.changes, "source": e.source,
                             "case": e.case.case.name, **e.floor.record()} for e in entries],
                "pairing": PAIRING_NOTE, "wall_s": round(wall, 1), "command": sys.argv,
                "versions": versions()}
    interrupt.enter()  # a Ctrl-C while the results are written is held until all are
    try:
        write_tables(args.out, "whatif", rows, fields, summary, table, time_use)
        for e in entries:
            if e.changes:
                (args.out / "variants").mkdir(exist_ok=True)
                write_atomic(args.out / "variants" / f"{e.name}.toml", variant_toml(
                    e.case, f"Variant {e.name!r} of {entries[0].name!r}: {e.changes}\n"
                    f"(cmdp-evaluate {e.source}; docs/levers.md)"))
        write_atomic(args.out / "settings.json",
                     json.dumps(settings, indent=2, default=str) + "\n")
    finally:
        interrupt.leave()
    print(table, end="")
    print(f"cmdp-evaluate: {len(rows)} episodes in {wall:.0f} s -> {args.out}")
    return 1 if any(not r["finished"] for r in rows) else 0
