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
- the crane's material and hoisting requests and their mean wait in its queue;

then, per crew type and time-use category, the variant's crew-seconds less the base's on each
floor (``deltas``), and the formwork crews' idle time for task areas by what blocks it
(``area_blockers``, ``blockers_table``).

One process, one seed after another (about 2 x 5-10 s a seed on a free core). ``--out``: every
per-seed number as JSON, written whole.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import cmdp_pymunk
from cmdp_pymunk.cases.levers import make_variant
from cmdp_pymunk.eventfloor.calibration import calibration_for
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.timeuse import CATEGORIES, time_use, totals
from training.cli import seed_list
from training.runs.runner import EpisodeRunner

STALL_S = 3600.0


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


def area_blockers(events, site, blocked_type: str = "FC") -> dict[str, float]:
    """The crew-seconds that crews of ``blocked_type`` spend idle for task areas
    (``idle_area``), by what blocks them: over each such stretch, the tasks on the plane
    whose areas conflict with a task of that type not started yet, sorted into the first
    kind that holds: ``paused, crew at the crane`` (a paused task whose crew waits for a lift),
    ``paused, crew away`` (a paused task, its crew walking to, loading at or back from a
    storage), ``worked`` (its crew at it) and none found (``other``), by the blocking task's
    crew type."""
    tasks = {t.id: t for t in site.tasks}
    ttype = {t.id: site.case.task_types[t.type].crew_type for t in site.tasks}
    started: dict[str, float] = {}
    on: dict[str, tuple[float, float]] = {}
    paused: dict[str, list[tuple[float, float, str]]] = {}
    acts: dict[str, list[tuple[float, str]]] = {}
    pause_open: dict[str, tuple[float, str]] = {}
    end = max((e.time_s for e in events), default=0.0)
    for e in events:
        if e.kind == "task_start":
            started[e.subject] = e.time_s
        elif e.kind == "task_finish":
            on[e.subject] = (started[e.subject], e.time_s)
        elif e.kind == "task_pause":
            pause_open[e.subject] = (e.time_s, e.crew)
        elif e.kind == "task_resume" and e.subject in pause_open:
            a, crew = pause_open.pop(e.subject)
            paused.setdefault(e.subject, []).append((a, e.time_s, crew))
        elif e.kind == "activity":
            acts.setdefault(e.crew, []).append((e.time_s, e.subject))
    for tid, t0 in started.items():
        on.setdefault(tid, (t0, end))

    def activity_at(crew, t):
        now = "?"
        for when, act in acts.get(crew, []):
            if when > t:
                break
            now = act
        return now

    mine = [tid for tid in tasks if ttype[tid] == blocked_type]
    out: dict[str, float] = {}
    blocked_crews = {c.id for c in site.crews if c.type == blocked_type}
    for crew, seq in acts.items():
        if crew not in blocked_crews:
            continue
        for k, (a, act) in enumerate(seq):
            if act != "idle_area":
                continue
            b = seq[k + 1][0] if k + 1 < len(seq) else end
            t = a
            while t < b:  # one look a second would be exact; every 5 s is plenty here
                waiting = [tid for tid in mine if started.get(tid, math.inf) > t]
                blockers = {tasks_id for w in waiting for o in tasks[w].conflicts
                            for tasks_id in (site.tasks[o].id,)
                            if on.get(tasks_id, (math.inf, 0))[0] <= t < on[tasks_id][1]}
                kind = "other"
                for tid in blockers:
                    pz = [p for p in paused.get(tid, []) if p[0] <= t < p[1]]
                    if pz:
                        state = activity_at(pz[0][2], t)
                        k2 = (f"{ttype[tid]} paused, crew at the crane" if state == "waiting"
                              else f"{ttype[tid]} paused, crew away")
                    else:
                        k2 = f"{ttype[tid]} worked"
                    if kind == "other" or "crane" in k2 or ("away" in k2 and "worked" in kind):
                        kind = k2
                step = min(5.0, b - t)
                out[kind] = out.get(kind, 0.0) + step
                t += step
    return out


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
                    "use": use,
                    "overlap_s": {m: loading_overlap(events, ids)
                                  for m, ids in by_material.items()},
                    "crane": crane_waits(events, c.crane.lift_time_s, c.crane.assist_time_s),
                    "fc_idle_area_by_blocker": area_blockers(events, engine.site)})
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


def deltas(rows: list[dict], variant: str) -> str:
    """Per crew type and category (``timeuse.CATEGORIES``), the mean over the seeds of the
    variant's crew-seconds less the base's on each floor, pymunk / event: where the variant's
    makespan difference comes from on each floor (categories under 60 s on both left out)."""
    by = {(r["entry"], r["floor"], r["seed"]): r for r in rows}
    seeds = sorted({r["seed"] for r in rows})
    types = sorted(rows[0]["use"])

    def delta(floor, key):
        vals = [key(by[(variant, floor, s)]) - key(by[("base", floor, s)]) for s in seeds]
        return sum(vals) / len(vals)

    lines = [f"Variant less base, mean over seeds {seeds[0]}-{seeds[-1]} ({len(seeds)}), "
             "pymunk / event", "", "| what | pymunk | event |", "|---|---|---|",
             f"| makespan (s) | {delta('pymunk', lambda r: r['makespan_s']):+,.0f} | "
             f"{delta('event', lambda r: r['makespan_s']):+,.0f} |"]
    for t in types:
        for c in CATEGORIES:
            p, e = (delta(f, lambda r, t=t, c=c: r["use"][t][c]) for f in ("pymunk", "event"))
            if max(abs(p), abs(e)) >= 60:
                lines.append(f"| {t} {c} (crew-s) | {p:+,.0f} | {e:+,.0f} |")
    return "\n".join(lines) + "\n"


def blockers_table(rows: list[dict]) -> str:
    """``area_blockers`` per (entry, floor), mean crew-seconds a floor over the seeds."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["entry"], r["floor"]), []).append(r)
    kinds = sorted({k for r in rows for k in r["fc_idle_area_by_blocker"]})
    lines = ["Formwork crews idle for task areas, by the blocking task (crew-s a floor)", "",
             "| blocked by | " + " | ".join(f"{e} {f}" for e, f in groups) + " |",
             "|---|" + "---|" * len(groups)]
    for k in kinds + ["all"]:
        cells = [sum(sum(r["fc_idle_area_by_blocker"].values()) if k == "all" else
                     r["fc_idle_area_by_blocker"].get(k, 0.0) for r in g) / len(g)
                 for g in groups.values()]
        lines.append(f"| {k} | " + " | ".join(f"{v:,.0f}" for v in cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--seeds", type=seed_list, default=seed_list("100-104"))
    p.add_argument("--variant", default="rebars.reorder_at=0.75")
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    rows = probe(cmdp_pymunk.load_case(None), a.variant, a.seeds)
    print(summary(rows), end="")
    print()
    print(deltas(rows, a.variant), end="")
    print()
    print(blockers_table(rows), end="")
    if a.out is not None:
        write_atomic(a.out, json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
