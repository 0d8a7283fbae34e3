"""``cmdp-search-rule``: search the weights of an extended Eq. 9 with CMA-ES (issue 17, item 7).

    cmdp-search-rule [--config training/configs/rule_search.toml] [--set key=value ...]
                     [--workers N] [--ray [ADDRESS]] [--out DIR] [--resume]

Writes into DIR: ``rule.json`` (the search's current estimate as a student file: use it
with ``cmdp-simulate --evaluator student:DIR/rule.json``; at the end, the mean that did best
against Eq. 9 on the selection seeds, with that check), ``history.csv`` (per generation: best
and mean paired difference to Eq. 9, step size, the mean weights), ``checkpoint.pkl`` (after
every generation; ``--resume`` continues from it exactly) and ``config.json`` (settings, case,
versions, command). The settings are ``training.search.rule.RuleSearchConfig``'s; a bad one
exits with 2 naming it and the fix. The floors run in worker processes, or on Ray actors with
``--ray`` (a Ray started here) or ``--ray ADDRESS`` (a cluster; docs/ray.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

import cmdp_pymunk
from training.cli import (
    SearchArgs,
    parse_search_args,
    workers_label,
    write_search_settings,
)
from training.config import RunConfig
from training.runs.backends import BackendError
from training.search.rule import RuleSearchConfig, search_rule

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "rule_search.toml"


def parse_args(argv: list[str] | None = None) -> SearchArgs:
    return parse_search_args("cmdp-search-rule", __doc__, DEFAULT_CONFIG, Path("runs/rule_search"),
                             "rule.json, history.csv and the checkpoint", argv)


class RuleSearchRunConfig(RuleSearchConfig, RunConfig):
    """``training.search.rule.RuleSearchConfig`` read like every run config (file, then
    ``--set``, every bad setting named with its fix)."""


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        config = RuleSearchRunConfig.load(args.config, list(args.overrides))
        case = cmdp_pymunk.load_case(config.case)
    except ValueError as err:  # CaseError is a ValueError
        print(f"cmdp-search-rule: {err}", file=sys.stderr)
        return 2
    write_search_settings(args.out, config, case, args.workers, args.ray)
    print(f"cmdp-search-rule: case {case.case.name!r}, weights of {', '.join(config.features)}; "
          f"{config.generations} generations x {config.seeds_per_generation} of "
          f"{len(config.train_seeds)} training seeds; " + workers_label(args.workers, args.ray))
    try:
        state = search_rule(case, config, args.out, args.workers, args.resume, args.progress,
                            args.ray)
    except (ValueError, BackendError) as err:
        print(f"cmdp-search-rule: {err}", file=sys.stderr)
        return 2
    for row in state.log:
        print(f"cmdp-search-rule: generation {row['generation']}: best {row['best']:+.0f} s, "
              f"mean {row['mean']:+.0f} s against Eq. 9 (sigma {row['sigma']:.3f})")
    sel = state.selection
    if sel is not None:
        seeds = f"{config.select_seeds[0]}..{config.select_seeds[-1]}"
        checked = ", ".join(f"{g}: {d:+.0f}" for g, d in sorted(sel["checked"].items()))
        print(f"cmdp-search-rule: means checked on selection seeds {seeds} (generation: "
              f"paired difference to Eq. 9, s): {checked}")
        if "note" in sel:
            print(f"cmdp-search-rule: {sel['note']}")
        else:
            kept = ("the start student" if sel["generation"] == 0
                    else f"generation {sel['generation']}'s mean")
            print(f"cmdp-search-rule: kept {kept}: "
                  f"{sel['ratio']:.3f} x Eq. 9, difference {sel['diff_mean_s']:+.0f} +- "
                  f"{sel['diff_ci95_s'] or 0:.0f} s ({sel['paired_seeds']} paired seeds; "
                  "picked on them, so report it on others)")
    print(f"cmdp-search-rule: the rule -> {args.out / 'rule.json'}")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
