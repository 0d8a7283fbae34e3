"""Compare a trained reaching policy with the scripted navigator, seed by seed (issue 4's bar).

    python -m training.commands.compare_reaching NAVIGATOR_RUN POLICY_RUN [--max-ratio 1.10]
                                                 [--min-reach 0.95]

Each RUN is the ``--out`` folder of ``cmdp-simulate --episodes N`` (one ``seed-S/summary.json``
per episode), made on the same seeds. Prints a Markdown table (makespan, tasks, reach rate per
seed, then the means) and the verdict: the policy passes when it finishes every task in every
seed, its mean makespan is at most ``max-ratio`` times the navigator's, and its mean reach rate
is at least ``min-reach``. Exit status 0 when it passes, 1 when it does not, 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cmdp_pymunk.report import makespan_stats


def load_run(folder: Path) -> dict[int, dict]:
    """seed -> summary.json of one ``cmdp-simulate --episodes N`` folder."""
    files = sorted(folder.glob("seed-*/summary.json"))
    if not files:
        raise ValueError(f"{folder}: no seed-*/summary.json; fix: give the --out folder of "
                         "`cmdp-simulate --episodes N` with N > 1")
    runs = {}
    for f in files:
        data = json.loads(f.read_text(encoding="utf-8"))
        runs[int(data["seed"])] = data
    return runs


def compare(navigator: dict[int, dict], policy: dict[int, dict], max_ratio: float,
            min_reach: float) -> tuple[str, bool]:
    """The Markdown table and whether the policy meets the bar."""
    seeds = sorted(navigator)
    if sorted(policy) != seeds:
        raise ValueError(f"the runs cover different seeds ({sorted(policy)} against {seeds}); "
                         "fix: run both with the same --seed and --episodes")
    lines = ["| seed | policy makespan (s) | tasks | reach rate | navigator makespan (s) | "
             "navigator reach rate |", "|---|---|---|---|---|---|"]
    for s in seeds:
        p, n = policy[s], navigator[s]
        lines.append(f"| {s} | {_seconds(p['makespan_s'])} | {p['tasks_finished']} | "
                     f"{p['reach_rate']:.3f} | {_seconds(n['makespan_s'])} | "
                     f"{n['reach_rate']:.3f} |")
    all_done = all(policy[s]["all_finished"] for s in seeds)
    mean = {}
    for name, run in (("policy", policy), ("navigator", navigator)):
        stats = makespan_stats([run[s] for s in seeds])
        mean[name] = stats["mean_s"] if stats["finished"] == len(seeds) else None
        mean[name + "_reach"] = stats["mean_reach_rate"]
    lines.append(f"| mean | **{_seconds(mean['policy'])}** | "
                 f"{'all in every seed' if all_done else 'NOT all'} | "
                 f"**{mean['policy_reach']:.3f}** | **{_seconds(mean['navigator'])}** | "
                 f"{mean['navigator_reach']:.3f} |")
    ratio = mean["policy"] / mean["navigator"] if mean["policy"] and mean["navigator"] else None
    ok = all_done and ratio is not None and ratio <= max_ratio and \
        mean["policy_reach"] >= min_reach
    lines += ["", f"makespan ratio {ratio:.3f} (bar {max_ratio:.2f})" if ratio else
              "makespan ratio: undefined (an episode did not finish)",
              f"reach rate {mean['policy_reach']:.3f} (bar {min_reach:.2f})",
              "verdict: " + ("PASS" if ok else "not met")]
    return "\n".join(lines), ok


def _seconds(value) -> str:
    return f"{value:,.0f}" if value else "-"


def main(argv: list[str] | None = None) -> int:
    from cmdp_pymunk import add_version_flag

    parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    add_version_flag(parser)
    parser.add_argument("navigator_run", type=Path)
    parser.add_argument("policy_run", type=Path)
    parser.add_argument("--max-ratio", type=float, default=1.10)
    parser.add_argument("--min-reach", type=float, default=0.95)
    args = parser.parse_args(argv)
    try:
        table, ok = compare(load_run(args.navigator_run), load_run(args.policy_run),
                            args.max_ratio, args.min_reach)
    except (ValueError, KeyError, json.JSONDecodeError) as err:
        print(f"compare_reaching: {err}", file=sys.stderr)
        return 2
    print(table)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
