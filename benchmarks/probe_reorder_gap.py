"""Why does the event floor undervalue an earlier reorder point? Per seed, both floors, the
base case and a reorder variant: where the reinforcing crews' time goes, and how often two
crews load at one storage at once (docs/event-floor.md, "Variants on the base's calibration").

    python benchmarks/probe_reorder_gap.py [--seeds 100-104] [--variant rebars.reorder_at=0.75]
        [--out FILE]

Eq. 9 and the scripted navigator, as ``benchmarks/validate_variants.py`` plays them, the event
floor on the base's calibration. Per (entry, floor) it prints the means over the seeds of

- the makespan;
- each crew type's crew-seconds loading, waiting for the crane and walking
  (``cmdp_pymunk.timeuse``, from the event log);
- ``overlap``: seconds in which two or more crews of one material load at its storage at once
  (from the ``activity`` events): on the pymunk floor each of them slows the others by Eq. 2
  (n x I_agent, the crews standing in the storage); on the event floor every loading crew is
  slowed by its type's calibrated ``fetch_invasion`` whatever the others do;
- the crane's material and hoisting requests and their mean wait in its queue.

One process, one seed after another (about 2 x 5-10 s a seed on a free core). ``--out``: every
per-seed number as JSON, written whole.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.levers import make_variant
from cmdp_pymunk.eventfloor.calibration import calibration_for
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.timeuse import time_use, totals
from training.cli import seed_list
from training.runs.runner import EpisodeRunner

STALL_S = 3600.0
KEPT = ("loading", "waiting_crane", "walking", "working")


def loading_overlap(events, crews_of_material: set[str]) -> float:
    """Seconds in which two or more of ``crews_of_material`` are loading (``fetching``) at
    once, from the log's ``activity`` events (a sweep over the starts and ends)."""
    edges, since = [], {}
    for e in events:
        if e.kind != "activity" or e.crew not in crews_of_material:
            continue
        if e.crew in since:
            edges.append((since.pop(e.crew), e.time_s))
        if e.subject == "fetching":
            since[e.crew] = e.time_s
    end = max((e.time_s for e in events), default=0.0)
    edges += [(t, end) for t in since.values()]
    points = sorted([(a, 1) for a, _ in edges] + [(b, -1) for _, b in edges])
    overlap, n, last = 0.0, 0, 0.0
    for t, step in points:
        if n >= 2:
            overlap += t - last
        n += step
        last = t
    return overlap


def crane_waits(events, lift_s: float, assist_s: float) -> dict[str, tuple[int, float]]:
    """Per request kind (material, task): how many, and the mean seconds from the request to
    the crane taking it up (its done time less its service time)."""
    asked: dict[tuple[str, str], float] = {}
    out: dict[str, list[float]] = {"material": [], "task": []}
    for e in events:
        if e.kind == "crane_request":
            asked[(e.crew, e.subject)] = e.time_s
        elif e.kind == "crane_done" and (e.crew, e.subject) in asked:
            service = lift_s if e.detail == "material" else assist_s
            out[e.detail].append(e.time_s - asked.pop((e.crew, e.subject)) - service)
    return {k: (len(v), sum(v) / len(v) if v else 0.0) for k, v in out.items()}


def probe(case, variant: str, seeds: list[int]) -> list[dict]:
    """Every seed of the base and the variant on both floors: one row per floor played."""
    calibration = calibration_for(case)
    rows = []
    for name, c in (("base", case), (variant, make_variant(case, variant).case)):
        types = {crew.id: crew.type for crew in c.crews}
        material_of = {tt.crew_type: tt.material for tt in c.task_types.values() if tt.material}
        by_material: dict[str, set[str]] = {}
        for crew in c.crews:
            material = material_of.get(crew.type)
            if material:
                by_material.setdefault(material, set()).add(crew.id)
        for fidelity, cal in (("pymunk", None), ("event", calibration)):
            runner = EpisodeRunner(c, STALL_S, None, False, None, fidelity, cal)
            for seed in seeds:
                engine, episode = runner.play("priority", "scripted", seed)
                events = engine.log.events
                end = engine.site.time_s
                use = totals(time_use(events, types, len(c.tasks), end))
                rows.append({
                    "entry": name, "floor": fidelity, "seed": seed, "makespan_s": end,
                    "use": {t: {k: use[t][k] for k in KEPT} for t in use},
                    "overlap_s": {m: loading_overlap(events, ids)
                                  for m, ids in by_material.items()},
                    "crane": crane_waits(events, c.crane.lift_time_s, c.crane.assist_time_s)})
                print(f"{name} {fidelity} {seed}: {end:,.0f} s", file=sys.stderr, flush=True)
    return rows


def summary(rows: list[dict]) -> str:
    """Means over the seeds per (entry, floor), as a Markdown table."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["entry"], r["floor"]), []).append(r)

    def mean(vals):
        vals = list(vals)
        return sum(vals) / len(vals)

    lines = ["| entry | floor | makespan | RC loading / crane wait / walking | "
             "FC loading / crane wait | HIC crane wait | rebar, template loading overlap | "
             "material lifts, mean queue wait | hoisting assists, mean queue wait |",
             "|---|---|---|---|---|---|---|---|---|"]
    for (entry, floor), g in groups.items():
        def use(t, k, g=g):
            return mean(r["use"].get(t, {}).get(k, 0.0) for r in g)
        lines.append(
            f"| {entry} | {floor} | {mean(r['makespan_s'] for r in g):,.0f} | "
            f"{use('RC', 'loading'):,.0f} / {use('RC', 'waiting_crane'):,.0f} / "
            f"{use('RC', 'walking'):,.0f} | {use('FC', 'loading'):,.0f} / "
            f"{use('FC', 'waiting_crane'):,.0f} | {use('HIC', 'waiting_crane'):,.0f} | "
            f"{mean(r['overlap_s'].get('rebars', 0.0) for r in g):,.0f}, "
            f"{mean(r['overlap_s'].get('templates', 0.0) for r in g):,.0f} | "
            f"{mean(r['crane']['material'][0] for r in g):.1f}, "
            f"{mean(r['crane']['material'][1] for r in g):,.0f} | "
            f"{mean(r['crane']['task'][0] for r in g):.1f}, "
            f"{mean(r['crane']['task'][1] for r in g):,.0f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=seed_list, default=seed_list("100-104"))
    p.add_argument("--variant", default="rebars.reorder_at=0.75")
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    rows = probe(cmdp_pymunk.load_case(None), a.variant, a.seeds)
    print(summary(rows), end="")
    if a.out is not None:
        write_atomic(a.out, json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
