"""The event floor against the pymunk floor, seed by seed (``cmdp-validate-event-floor``,
``training/commands/validate_event_floor.py``; what is compared and issue 30's criteria are
that command's documentation): each floor's rows over the seeds (the pymunk floor's kept
between runs of the same case), the comparison and its Markdown table.

It sits beside ``training/eventfloor/fitting.py`` rather than in ``cmdp_pymunk/eventfloor``:
it plays the agents' strategies on the run machinery's worker processes, which the
simulation core may not import.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from cmdp_pymunk.timeuse import CATEGORIES, totals
from training.runs.backends import open_backend
from training.runs.paired import mean_ci, p80
from training.runs.runner import TIME_USE, EpisodeRunner

DEFAULT_STRATEGIES = ("priority", "nearest", "ga:models/ga_priorities.json",
                      "student:models/searched_rule.json", "models/stage2_desired_position.zip")
REFERENCE = "priority"
# issue 30's criteria
MIN_CORRELATION, MAX_GAP, MAX_TIME_USE_GAP, MAX_PAIRED_GAP = 0.9, 0.03, 0.15, 0.5
TIME_USE_SHOWN = ("walking", "working", "loading", "idle_predecessor", "idle_area",
                  "waiting_crane", "no_target", "disrupted")


def floor_job(runner: EpisodeRunner, strategy: str, seed: int) -> dict:
    start = time.process_time()
    row = runner.run(strategy, "scripted", seed)
    row["cpu_s"] = time.process_time() - start
    return row


def floor_rows(runner_args: tuple, strategies: list[str], seeds: list[int],
               workers: int | None, kept: dict | None = None) -> dict[str, list[dict]]:
    """Every strategy's rows over the seeds on the floor ``runner_args`` builds; rows in
    ``kept`` (strategy -> seed as text -> row) are taken from there, and the new ones added
    to it."""
    kept = {} if kept is None else kept
    jobs = [(s, seed) for s in strategies for seed in seeds
            if str(seed) not in kept.get(s, {})]
    if jobs:
        with open_backend(floor_job, runner_args, workers) as backend:
            rows = backend.map(jobs)
        for (strategy, seed), row in zip(jobs, rows, strict=True):
            kept.setdefault(strategy, {})[str(seed)] = row
    return {s: [kept[s][str(seed)] for seed in seeds] for s in strategies}


def case_key(case) -> str:
    """The whole case, hashed: pymunk rows are reused only for the very same case."""
    import hashlib

    return hashlib.sha256(case.model_dump_json().encode()).hexdigest()[:16]


def paired_on_many(event_many: dict[str, list[dict]], pymunk: dict[str, list[dict]]) -> dict:
    """Each strategy's paired difference to Eq. 9 on the event floor's many seeds, against
    the pymunk floor's on the validation seeds (see the module doc)."""
    ref = _makespans(event_many[REFERENCE])
    out = {}
    for strategy, rows in event_many.items():
        if strategy == REFERENCE:
            continue
        diffs = [a - b for a, b in zip(_makespans(rows), ref, strict=True) if a and b]
        mean, _, half = mean_ci(diffs)
        p_ref, p_own = _makespans(pymunk[REFERENCE]), _makespans(pymunk[strategy])
        p_mean, _, p_half = mean_ci([a - b for a, b in zip(p_own, p_ref, strict=True)
                                     if a and b])
        out[strategy] = {"event_many_paired_s": mean, "event_many_paired_half_s": half,
                         "event_many_mean_s": mean_ci(_makespans(rows))[0],
                         "pymunk_paired_s": p_mean, "pymunk_paired_half_s": p_half,
                         "ratio": mean / p_mean if p_mean else None,
                         "inside_pymunk_interval": p_half is not None
                         and abs(mean - p_mean) <= p_half}
    out[REFERENCE] = {"event_many_mean_s": mean_ci(ref)[0]}
    return out


def _makespans(rows: list[dict]) -> list[float | None]:
    return [r["makespan_s"] for r in rows]


def _gap(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or b == 0 else a / b - 1.0


def compare(pymunk: dict[str, list[dict]], event: dict[str, list[dict]],
            event_many: dict[str, list[dict]] | None = None) -> dict:
    """The validation numbers (see the module doc) from the two floors' rows (and the event
    floor's on many seeds, for the paired differences and the ranking)."""
    out: dict = {"strategies": {}, "criteria": {},
                 "many_seeds": paired_on_many(event_many, pymunk) if event_many else None}
    ref_p, ref_e = _makespans(pymunk[REFERENCE]), _makespans(event[REFERENCE])
    for strategy in pymunk:
        mp, me = _makespans(pymunk[strategy]), _makespans(event[strategy])
        both = [(a, b) for a, b in zip(mp, me, strict=True) if a and b]
        corr = float(np.corrcoef(np.array(both).T)[0, 1]) if len(both) > 2 else None
        entry = {
            "pymunk_mean_s": mean_ci(mp)[0], "event_mean_s": mean_ci(me)[0],
            "pymunk_p80_s": p80(mp), "event_p80_s": p80(me),
            "correlation": corr,
            "pymunk_unfinished": sum(not v for v in mp), "event_unfinished": sum(not v for v in me),
            "pymunk_cpu_s": float(np.mean([r["cpu_s"] for r in pymunk[strategy]])),
            "event_cpu_s": float(np.mean([r["cpu_s"] for r in event[strategy]])),
            "pymunk_makespans_s": mp, "event_makespans_s": me,
        }
        entry["mean_gap"] = _gap(entry["event_mean_s"], entry["pymunk_mean_s"])
        entry["p80_gap"] = _gap(entry["event_p80_s"], entry["pymunk_p80_s"])
        if strategy != REFERENCE:
            for name, own, ref in (("pymunk", mp, ref_p), ("event", me, ref_e)):
                diffs = [a - b for a, b in zip(own, ref, strict=True) if a and b]
                mean, _, half = mean_ci(diffs)
                entry[f"{name}_paired_s"], entry[f"{name}_paired_half_s"] = mean, half
            p, e = entry["pymunk_paired_s"], entry["event_paired_s"]
            entry["paired_ratio"] = e / p if p else None
        out["strategies"][strategy] = entry
    order_p = sorted(pymunk, key=lambda s: out["strategies"][s]["pymunk_mean_s"] or np.inf)
    order_e = sorted(pymunk, key=lambda s: out["strategies"][s]["event_mean_s"] or np.inf)
    out["ranking"] = {"pymunk": order_p, "event": order_e}
    out["time_use"] = {floor: _time_use(rows[REFERENCE])
                       for floor, rows in (("pymunk", pymunk), ("event", event))}
    ref = out["strategies"][REFERENCE]
    gaps = [abs(_gap(out["time_use"]["event"][ct][c], v))
            for ct, use in out["time_use"]["pymunk"].items() for c, v in use.items()
            if v >= 0.02 * sum(use.values()) and ct in out["time_use"]["event"]]
    many = out.get("many_seeds")
    if many:  # the paired differences and ranking on the event floor's many seeds
        ratios = [e["ratio"] for s, e in many.items() if s != REFERENCE]
        order_e = sorted(pymunk, key=lambda s: many[s]["event_many_mean_s"] or np.inf)
        out["ranking"]["event"] = order_e
    else:
        ratios = [e["paired_ratio"] for s, e in out["strategies"].items() if s != REFERENCE]
    out["criteria"] = {
        "correlation_eq9": (ref["correlation"], (ref["correlation"] or 0) >= MIN_CORRELATION),
        "mean_within_3pct": (ref["mean_gap"], abs(ref["mean_gap"] or 1) <= MAX_GAP),
        "p80_within_3pct": (ref["p80_gap"], abs(ref["p80_gap"] or 1) <= MAX_GAP),
        "time_use_within_15pct": (max(gaps, default=None),
                                  bool(gaps) and max(gaps) <= MAX_TIME_USE_GAP),
        "same_ranking": (None, order_p == order_e),
        "paired_within_50pct": (ratios, all(r is not None and abs(r - 1) <= MAX_PAIRED_GAP
                                            for r in ratios)),
        "paired_inside_pymunk_interval": (None, bool(many) and all(
            e["inside_pymunk_interval"] for s, e in many.items() if s != REFERENCE)),
        "unfinished": (sum(e["event_unfinished"] for e in out["strategies"].values()),
                       all(e["event_unfinished"] <= e["pymunk_unfinished"]
                           for e in out["strategies"].values())),
    }
    return out


def _time_use(rows: list[dict]) -> dict[str, dict[str, float]]:
    """Mean crew-seconds per floor by crew type and category (finished floors)."""
    done = [r for r in rows if r["finished"]]
    out: dict[str, dict[str, float]] = {}
    for row in done:
        for ct, use in totals(row[TIME_USE]).items():
            acc = out.setdefault(ct, dict.fromkeys(CATEGORIES, 0.0))
            for c, v in use.items():
                acc[c] += v / len(done)
    return out


def _s(v, digits=0) -> str:
    return "—" if v is None else f"{v:,.{digits}f}"


def _pct(v) -> str:
    return "—" if v is None else f"{100 * v:+.1f} %"


def markdown(result: dict, seeds_text: str) -> str:
    """The validation's tables (see the module doc)."""
    lines = [f"Seeds {seeds_text}; mean and P80 makespans in seconds; paired difference to "
             "Eq. 9 on the same seeds, mean ± 95 % interval.", "",
             "| strategy | pymunk mean | event mean | gap | pymunk P80 | event P80 | gap | "
             "per-seed r | pymunk vs Eq. 9 | event vs Eq. 9 | CPU s/floor pymunk / event |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for strategy, e in result["strategies"].items():
        paired = ("—", "—") if strategy == REFERENCE else tuple(
            f"{e[f'{f}_paired_s']:+,.0f} ± {_s(e[f'{f}_paired_half_s'])}"
            for f in ("pymunk", "event"))
        lines.append(
            f"| {strategy} | {_s(e['pymunk_mean_s'])} | {_s(e['event_mean_s'])} | "
            f"{_pct(e['mean_gap'])} | {_s(e['pymunk_p80_s'])} | {_s(e['event_p80_s'])} | "
            f"{_pct(e['p80_gap'])} | {_s(e['correlation'], 3)} | {paired[0]} | {paired[1]} | "
            f"{e['pymunk_cpu_s']:.2f} / {e['event_cpu_s']:.3f} |")
    many = result.get("many_seeds")
    if many:
        lines += ["", f"Paired difference to Eq. 9: the event floor on {result['event_seeds']} "
                  f"against the pymunk floor on {seeds_text} (mean ± 95 % interval):", "",
                  "| strategy | event floor, many seeds | pymunk floor | ratio | inside the "
                  "pymunk interval |", "|---|---|---|---|---|"]
        for strategy, e in many.items():
            if strategy == REFERENCE:
                continue
            lines.append(f"| {strategy} | {e['event_many_paired_s']:+,.0f} ± "
                         f"{_s(e['event_many_paired_half_s'])} | {e['pymunk_paired_s']:+,.0f} ± "
                         f"{_s(e['pymunk_paired_half_s'])} | {_s(e['ratio'], 2)} | "
                         f"{'yes' if e['inside_pymunk_interval'] else 'no'} |")
    lines += ["", "Eq. 9's crew-hours per floor by crew type (pymunk / event):", "",
              "| crew type | " + " | ".join(TIME_USE_SHOWN) + " |",
              "|---|" + "---|" * len(TIME_USE_SHOWN)]
    tu = result["time_use"]
    for ct in sorted(tu["pymunk"]):
        event_use = tu["event"].get(ct, {})
        cells = [f"{tu['pymunk'][ct][c] / 3600:.1f} / {event_use.get(c, 0) / 3600:.1f}"
                 for c in TIME_USE_SHOWN]
        lines.append(f"| {ct} | " + " | ".join(cells) + " |")
    lines += ["", "Issue 30's criteria:", ""]
    for name, (value, ok) in result["criteria"].items():
        shown = (", ".join(_s(v, 2) for v in value) if isinstance(value, list)
                 else _s(value, 3) if isinstance(value, float) else _s(value))
        lines.append(f"- {name}: {shown} — {'met' if ok else 'NOT met'}")
    r = result["ranking"]
    lines.append(f"- ranking, best first: pymunk {', '.join(r['pymunk'])}; event "
                 f"{', '.join(r['event'])}")
    return "\n".join(lines) + "\n"


def event_floors(case, calibration, strategies: list[str], seeds: list[int],
                 many_seeds: list[int], workers: int | None) -> tuple[dict, dict]:
    """The event floor's rows on the validation ``seeds`` and on ``many_seeds`` (its paired
    differences and ranking, module doc), each strategy -> rows in seed order."""
    event_args = (case, 3600.0, None, False, None, "event", calibration)
    event_many = floor_rows(event_args, strategies, many_seeds, workers)
    event = {s: [r for r, seed in zip(rows, many_seeds, strict=True) if seed in set(seeds)]
             for s, rows in event_many.items()} if set(seeds) <= set(many_seeds) \
        else floor_rows(event_args, strategies, seeds, workers)
    return event, event_many


def kept_pymunk_rows(case, strategies: list[str], seeds: list[int], workers: int | None,
                     out: Path, fresh: bool) -> dict[str, list[dict]]:
    """The pymunk floor's rows, those of an earlier run on the very same case taken from
    ``out/pymunk_rows.json`` (unless ``fresh``) and the file rewritten whole with the new."""
    cache = out / "pymunk_rows.json"
    kept = {}
    if cache.is_file() and not fresh:
        stored = json.loads(cache.read_text(encoding="utf-8"))
        kept = stored["rows"] if stored.get("case") == case_key(case) else {}
    pymunk = floor_rows((case, 3600.0), strategies, seeds, workers, kept)
    tmp = cache.with_suffix(".tmp")
    tmp.write_text(json.dumps({"case": case_key(case), "rows": kept}), encoding="utf-8")
    tmp.replace(cache)
    return pymunk



def write_validation(out: Path, record: dict, table: str) -> None:
    """``validation.json`` and ``validation.md``, each whole or not at all."""
    for name, text in (("validation.json", json.dumps(record, indent=1, default=str)),
                       ("validation.md", table)):
        tmp = out / (name + ".tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(out / name)
