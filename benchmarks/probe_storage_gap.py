"""Why does the event floor get the sign of a storage move wrong? Per seed, both floors, the
base case and a storage variant: where each crew type's time goes, and every walk by where it
came from and where it went (docs/event-floor.md, "Variants on the base's calibration").

    python benchmarks/probe_storage_gap.py [--seeds 100-105] [--variant ST-rebars.x_m=-6]
        [--logs DIR] [--out FILE]

Eq. 9 and the scripted navigator, as ``benchmarks/validate_variants.py`` plays them, the event
floor on the base's calibration. Per (entry, floor) and seed it reads from the event log

- the makespan, and each crew type's crew-seconds by time-use category
  (``cmdp_pymunk.timeuse``: walking, loading, working, idle for predecessors or areas, waiting
  for the crane);
- every walk (``walks``: an ``activity`` ``navigating`` up to the crew's next activity), by
  crew type and kind: from a start, a storage or a task to a storage or a task (the ``reach``
  event that ends it), or broken off (the crew went idle or its target changed): how many,
  and their seconds;
- every stay at a storage (``fetching``) and at a task (``tasking``): how many, and their
  seconds.

It prints the means over the seeds, then the variant's less the base's on each floor
(``deltas``): the component whose change differs in sign or size between the floors is where
the gap sits. ``--logs``: each floor's event log kept as ``<entry>-<floor>-<seed>.csv`` and
read back instead of playing that floor again (the floors are deterministic). One process, one
floor after another (about 5-10 s a pymunk floor on a free core). ``--out``: every per-seed
number as JSON, written whole. ``--event-seeds 100-399``: instead, the variant less the
base on event floors alone over many seeds, by blocks of 40 (is the event floor's sign its
model or its draw of seeds?).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.levers import make_variant
from cmdp_pymunk.eventfloor.calibration import calibration_for
from cmdp_pymunk.events import EventLog, read_csv, write_atomic
from cmdp_pymunk.timeuse import CATEGORIES, time_use, totals
from training.cli import seed_list
from training.runs.paired import mean_ci
from training.runs.runner import EpisodeRunner

STALL_S = 3600.0


def target_kind(target: str, storages: dict[str, str]) -> str:
    """A reached target's kind: ``storage <material>`` or ``task`` (a component), ``outlet``."""
    if target in storages:
        return f"storage {storages[target]}"
    return "outlet" if target.lower().startswith("outlet") else "task"


def walks(events, storages: dict[str, str]) -> list[tuple]:
    """Every walk of the log: (crew, from kind, to kind, from target, to target, start s,
    seconds). A walk begins at an ``activity`` ``navigating`` and ends at the crew's next
    ``activity``; its ``to`` is the target of a ``reach`` at that second (``broken`` where
    none: the crew went idle or turned to another target, which starts a new walk), its
    ``from`` the crew's last reached target (``start`` before any)."""
    out = []
    last_reach: dict[str, tuple[float, str]] = {}
    open_walk: dict[str, float] = {}
    came_from: dict[str, str] = {}  # crew -> the last target it reached
    for t, kind, crew, subject, *_ in events:
        if kind == "reach":
            last_reach[crew] = (t, subject)
        elif kind == "activity":
            if crew in open_walk:
                since = open_walk.pop(crew)
                reached = last_reach.get(crew)
                to = reached[1] if reached is not None and reached[0] == t else "broken"
                came = came_from.get(crew, "start")
                out.append((crew, _kind(came, storages), _kind(to, storages), came, to, since,
                            t - since))
                if to != "broken":
                    came_from[crew] = to
            if subject == "navigating":
                open_walk[crew] = t
    return out


def _kind(target: str, storages: dict[str, str]) -> str:
    return target if target in ("start", "broken") else target_kind(target, storages)


def stays(events, activity: str) -> list[tuple[str, float]]:
    """(crew, seconds) of each stretch in ``activity`` (``fetching``: loading at a storage;
    ``tasking``: working), from the log's ``activity`` events."""
    out, since = [], {}
    for t, kind, crew, subject, *_ in events:
        if kind != "activity":
            continue
        if crew in since:
            out.append((crew, t - since.pop(crew)))
        if subject == activity:
            since[crew] = t
    return out


def floor_row(events, end_s: float, case) -> dict:
    """One floor's numbers (see the module doc) from its event log."""
    types = {c.id: c.type for c in case.crews}
    storages = {s.id: s.material for s in case.storages}
    use = totals(time_use(events, types, len(case.tasks), end_s))
    walk_stats: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
    by_pair: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
    for crew, came, to, came_id, to_id, _, seconds in walks(events, storages):
        for stats, key in ((walk_stats, f"{types[crew]} {came} -> {to}"),
                           (by_pair, f"{types[crew]}|{came} -> {to}|{came_id}|{to_id}")):
            stats[key][0] += 1
            stats[key][1] += seconds
    stay_stats: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
    for activity in ("fetching", "tasking"):
        for crew, seconds in stays(events, activity):
            s = stay_stats[f"{types[crew]} {activity}"]
            s[0] += 1
            s[1] += seconds
    return {"makespan_s": end_s, "use": use, "walks": dict(walk_stats),
            "walk_pairs": dict(by_pair), "stays": dict(stay_stats)}


def play(case, fidelity: str, calibration, seed: int, log_path: Path | None):
    """One floor's (events, makespan): read from ``log_path`` where it is there, else played
    (and kept there)."""
    if log_path is not None and log_path.is_file():
        events = read_csv(log_path)
        end = float(log_path.with_suffix(".end").read_text())
        return events, end
    runner = EpisodeRunner(case, STALL_S, None, False, None, fidelity, calibration)
    engine, _ = runner.play("priority", "scripted", seed)
    events, end = engine.log.events, engine.site.time_s
    if log_path is not None:
        log = EventLog()
        log.events = engine.log.events
        log.write_csv(log_path)
        write_atomic(log_path.with_suffix(".end"), f"{end!r}\n")
    return events, end


def probe(case, variant: str, seeds: list[int], logs: Path | None = None) -> list[dict]:
    """Every seed of the base and the variant on both floors: one row per floor played."""
    calibration = calibration_for(case)
    rows = []
    if logs is not None:
        logs.mkdir(parents=True, exist_ok=True)
    for seed in seeds:
        for name, c in (("base", case), (variant, make_variant(case, variant).case)):
            for fidelity, cal in (("event", calibration), ("pymunk", None)):
                path = None if logs is None else logs / f"{name}-{fidelity}-{seed}.csv"
                events, end = play(c, fidelity, cal, seed, path)
                rows.append({"entry": name, "floor": fidelity, "seed": seed,
                             **floor_row(events, end, c)})
                print(f"{name} {fidelity} {seed}: {end:,.0f} s", file=sys.stderr, flush=True)
    return rows


def _mean(vals) -> float:
    vals = list(vals)
    return sum(vals) / len(vals) if vals else 0.0


def deltas(rows: list[dict], variant: str) -> str:
    """The variant less the base, mean a floor over the seeds both floors finished, pymunk /
    event: the makespan, each crew type's time use (categories under 60 crew-s on both left
    out), and the walks and stays by kind (count, crew-seconds, mean seconds, each floor's
    base then variant)."""
    by = {(r["entry"], r["floor"], r["seed"]): r for r in rows}
    seeds = sorted({r["seed"] for r in rows
                    if all((e, f, r["seed"]) in by for e in ("base", variant)
                           for f in ("pymunk", "event"))})

    def delta(floor, key):
        return _mean(key(by[(variant, floor, s)]) - key(by[("base", floor, s)]) for s in seeds)

    lines = [f"Variant less base, mean a floor over seeds {seeds[0]}-{seeds[-1]} "
             f"({len(seeds)})", "", "| what | pymunk | event |", "|---|---|---|",
             f"| makespan (s) | {delta('pymunk', lambda r: r['makespan_s']):+,.0f} | "
             f"{delta('event', lambda r: r['makespan_s']):+,.0f} |"]
    for t in sorted(rows[0]["use"]):
        for c in CATEGORIES:
            p, e = (delta(f, lambda r, t=t, c=c: r["use"][t][c]) for f in ("pymunk", "event"))
            if max(abs(p), abs(e)) >= 60:
                lines.append(f"| {t} {c} (crew-s) | {p:+,.0f} | {e:+,.0f} |")
    for part in ("walks", "stays"):
        kinds = sorted({k for r in rows for k in r[part]})
        lines += ["", f"{part}: count, crew-s a floor and mean s (base -> variant), "
                  "pymunk | event", "",
                  "| kind | pymunk n | pymunk crew-s | pymunk mean s | event n | event crew-s | "
                  "event mean s |", "|---|---|---|---|---|---|---|"]
        for k in kinds:
            cells = []
            for floor in ("pymunk", "event"):
                n = [_mean(by[(e, floor, s)][part].get(k, [0, 0.0])[0] for s in seeds)
                     for e in ("base", variant)]
                sec = [_mean(by[(e, floor, s)][part].get(k, [0, 0.0])[1] for s in seeds)
                       for e in ("base", variant)]
                mean_s = [sec[i] / n[i] if n[i] else 0.0 for i in (0, 1)]
                cells += [f"{n[0]:.1f} -> {n[1]:.1f}", f"{sec[0]:,.0f} -> {sec[1]:,.0f}",
                          f"{mean_s[0]:.1f} -> {mean_s[1]:.1f}"]
            lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def split_walks(rows: list[dict], variant: str) -> str:
    """The variant's walking crew-seconds less the base's, per walk kind and floor, split in
    two (mean a floor over the seeds both floors finished): ``same walks``, the walks between
    the same two targets in both entries of a seed, their count in the variant times their
    mean seconds' change (the floor's time for a walk, under the move); ``mix``, the rest
    (other walks, or more or fewer of them: the sequencing)."""
    by = {(r["entry"], r["floor"], r["seed"]): r for r in rows}
    seeds = sorted({r["seed"] for r in rows
                    if all((e, f, r["seed"]) in by for e in ("base", variant)
                           for f in ("pymunk", "event"))})
    out: dict[tuple[str, str], list[float]] = defaultdict(lambda: [0.0, 0.0])
    for floor in ("pymunk", "event"):
        for seed in seeds:
            base = by[("base", floor, seed)]["walk_pairs"]
            var = by[(variant, floor, seed)]["walk_pairs"]
            for key in set(base) | set(var):
                kind = key.split("|")[0] + " " + key.split("|")[1]
                nb, sb = base.get(key, [0, 0.0])
                nv, sv = var.get(key, [0, 0.0])
                same = nv * (sv / nv - sb / nb) if nb and nv else 0.0
                cell = out[(kind, floor)]
                cell[0] += same / len(seeds)
                cell[1] += (sv - sb - same) / len(seeds)
    kinds = sorted({k for k, _ in out})
    lines = ["Walking crew-s a floor, variant less base: same walks (the walk's time) + mix",
             "", "| walk kind | pymunk same | pymunk mix | event same | event mix |",
             "|---|---|---|---|---|"]
    totals_ = [0.0] * 4
    for k in kinds:
        cells = [*out[(k, "pymunk")], *out[(k, "event")]]
        if max(abs(c) for c in cells) < 20:
            continue
        totals_ = [a + b for a, b in zip(totals_, cells, strict=True)]
        lines.append(f"| {k} | " + " | ".join(f"{c:+,.0f}" for c in cells) + " |")
    lines.append("| all shown | " + " | ".join(f"{c:+,.0f}" for c in totals_) + " |")
    return "\n".join(lines) + "\n"


def event_only(case, variant: str, seeds: list[int], block: int = 40) -> str:
    """The variant less the base on event floors alone over many seeds (cheap: about 0.1 s a
    floor): the mean and its 95 % interval, then by blocks of ``block`` seeds (how far a
    40-seed estimate of the lever drifts from seed set to seed set)."""
    calibration = calibration_for(case)
    spans = {}
    for name, c in (("base", case), (variant, make_variant(case, variant).case)):
        runner = EpisodeRunner(c, STALL_S, None, False, None, "event", calibration)
        spans[name] = [runner.play("priority", "scripted", s)[0].site.time_s for s in seeds]
    diffs = [v - b for b, v in zip(spans["base"], spans[variant], strict=True)]
    mean, _, half = mean_ci(diffs)
    lines = [f"event floor, {variant} less base, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)}): "
             f"{mean:+,.0f} +- {half:,.0f} s"]
    for k in range(0, len(diffs), block):
        m, _, h = mean_ci(diffs[k:k + block])
        lines.append(f"  seeds {seeds[k]}-{seeds[min(k + block, len(seeds)) - 1]}: "
                     f"{m:+,.0f} +- {h:,.0f} s")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=seed_list, default=seed_list("100-105"))
    p.add_argument("--variant", default="ST-rebars.x_m=-6")
    p.add_argument("--logs", type=Path, default=None)
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--event-seeds", type=seed_list, default=None,
                   help="instead: the variant less the base on event floors alone over these "
                        "seeds, with 40-seed blocks (e.g. 100-399)")
    a = p.parse_args(argv)
    if a.event_seeds is not None:
        print(event_only(cmdp_pymunk.load_case(None), a.variant, a.event_seeds), end="")
        return 0
    rows = probe(cmdp_pymunk.load_case(None), a.variant, a.seeds, a.logs)
    print(deltas(rows, a.variant), end="")
    print()
    print(split_walks(rows, a.variant), end="")
    if a.out is not None:
        write_atomic(a.out, json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
