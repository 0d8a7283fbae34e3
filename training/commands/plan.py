"""``cmdp-plan``: search a case's levers for the plan with the lowest P80 makespan, the lowest
cost, or the cost/P80 Pareto front (issue 42 item 5; docs/levers.md, "A plan search").

    cmdp-plan [--case FILE] [--objective p80|cost|pareto] [--max-cost-ratio R] [--trials 40]
              [--search-seeds 1000-1015] [--confirm-seeds 2000-2019] [--confirm 3]
              [--min-seeds 4] [--reduction-factor 2] [--batch 4] [--seed 0]
              [--sampler tpe-joint|tpe-independent|nsga2|random] [--screen crew-pairs|none]
              [--startup-trials 8]
              [--calibration FILE] [--confirm-fidelity pymunk|event] [--no-alone]
              [--workers N] [--ray [ADDRESS]] [--out DIR] [--resume] [--no-progress]

Optuna searches the levers (crew counts, reorder points, crane lift batches, storage spots and
capacities: the case's ``[levers]``, or one crew fewer or more and reorder points up to half a
storage when it has none) on the event floor, every plan on the same search seeds in the same
order (common random numbers), plans picked by ``--sampler`` (TPE over all levers together by
default), its seeds spent by successive halving (NSGA-II and every seed for ``pareto``);
``--max-cost-ratio 1.0`` keeps only plans no dearer than the case (Optuna's trial constraints);
then the best ``--confirm`` plans play held-out ``--confirm-seeds`` on the pymunk floor, paired
with the case as written. Writes into DIR: ``plan.toml`` (the chosen plan as a case file:
``cmdp-simulate --case DIR/plan.toml``), ``plans/planK.toml``, ``media/pareto.png``,
``levers.md`` and ``levers.csv`` (each change alone and together), ``trials.csv``,
``summary.json``, ``plan.journal`` (Optuna's study: ``--resume`` continues it) and
``episodes.jsonl`` (every floor played; a resumed run plays none twice). The logic is
``training.search.plan_search``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cmdp_pymunk
from training.cli import OneLineParser, add_ray_option, plain, positive_int, workers_label

DEFAULT_OUT = Path("runs/plan")


def parse_args(argv: list[str] | None = None):
    from training.cli import seed_list
    from training.fidelity import CALIBRATION_HELP
    from training.search.plan_config import OBJECTIVES, SAMPLERS, SCREENS, PlanConfig

    d = PlanConfig()
    p = OneLineParser(prog="cmdp-plan", description=plain(__doc__))
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--case", type=Path, default=None, help="the case (default: the built-in)")
    p.add_argument("--objective", choices=OBJECTIVES, default=d.objective,
                   help="p80: the lowest P80 makespan; cost: the lowest mean cost; pareto: "
                        "the front of both (default p80)")
    p.add_argument("--trials", type=positive_int, default=d.trials,
                   help="plans to try, the case as written first (default %(default)s)")
    p.add_argument("--search-seeds", type=seed_list, default=list(d.search_seeds),
                   help="the seeds the search plays, in this order for every plan "
                        "(default 1000-1015)")
    p.add_argument("--confirm-seeds", type=seed_list, default=list(d.confirm_seeds),
                   help="held-out seeds the best plans are confirmed on, none of them a "
                        "search seed (default 2000-2019)")
    p.add_argument("--confirm", type=positive_int, default=d.confirm,
                   help="how many of the best plans are confirmed (default %(default)s)")
    p.add_argument("--min-seeds", type=positive_int, default=d.min_seeds,
                   help="search seeds every plan plays before the pruner first compares "
                        "(default %(default)s)")
    p.add_argument("--reduction-factor", type=positive_int, default=d.reduction_factor,
                   help="each rung keeps the best 1/N of the plans and doubles (N) their "
                        "seeds (default %(default)s)")
    p.add_argument("--batch", type=positive_int, default=d.batch,
                   help="trials asked together; results do not depend on --workers "
                        "(default %(default)s)")
    p.add_argument("--max-cost-ratio", type=float, default=None, metavar="R",
                   help="p80/pareto: a plan is feasible only when its mean cost is at most R x "
                        "the case's on the same seeds (1.0: no dearer than the case); Optuna's "
                        "constraints, not a penalty (default: no bound)")
    p.add_argument("--no-alone", action="store_true",
                   help="skip each change of the chosen plan alone in levers.md (a pymunk floor "
                        "per change and held-out seed); the plan together is still measured")
    p.add_argument("--sampler", choices=SAMPLERS, default=None,
                   help="what picks the plans: tpe-joint (TPE over every lever at once, so "
                        "two levers that pay only together are sampled together; the default "
                        "for p80 and cost, as Optuna 5.0's TPE), tpe-independent (TPE per "
                        "lever), nsga2 (the default for pareto) or random")
    p.add_argument("--screen", choices=SCREENS, default=d.screen,
                   help="plans tried first, after the case: crew-pairs (each crew type one "
                        "fewer or more, and every two types one more each: crews that pay "
                        "only together; the default) or none")
    p.add_argument("--startup-trials", type=positive_int, default=d.startup_trials,
                   help="random plans TPE tries before it models them (default %(default)s)")
    p.add_argument("--seed", type=int, default=d.seed, help="the sampler's seed")
    p.add_argument("--evaluator", default=d.evaluator,
                   help="the target evaluator every floor runs (default priority, Eq. 9)")
    p.add_argument("--calibration", type=Path, default=None, metavar="PATH",
                   help="the event floor's calibration, which the search plays on"
                        + CALIBRATION_HELP.removeprefix("with --fidelity event: the event "
                                                        "floor's calibration"))
    p.add_argument("--confirm-fidelity", choices=("pymunk", "event"), default="pymunk",
                   help="the floor of the confirmation and the levers table (default pymunk, "
                        "the ground truth)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="worker processes (default: every core), or Ray actors with --ray")
    add_ray_option(p)
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="the run folder")
    p.add_argument("--resume", action="store_true", help="continue the search in --out")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    a = p.parse_args(argv)
    config = PlanConfig(a.objective, a.trials, tuple(a.search_seeds), tuple(a.confirm_seeds),
                        a.min_seeds, a.reduction_factor, a.batch, a.confirm,
                        a.confirm_fidelity, a.evaluator, a.seed,
                        max_cost_ratio=a.max_cost_ratio, alone=not a.no_alone,
                        sampler=a.sampler, startup_trials=a.startup_trials, screen=a.screen)
    return a, config


def main(argv: list[str] | None = None) -> int:
    from cmdp_pymunk.cases.load import CaseError
    from training.fidelity import resolve_floor
    from training.runs.backends import BackendError
    from training.search.plan_outputs import trial_rows, write_outputs
    from training.search.plan_search import search_plans

    a, config = parse_args(argv)
    try:
        import optuna  # noqa: F401
    except ImportError:
        print("cmdp-plan: needs Optuna; fix: pip install -e '.[plan]' (optuna==5.0.0)",
              file=sys.stderr)
        return 2
    try:
        case = cmdp_pymunk.load_case(a.case)
        floor = resolve_floor(case, a.case, "event", a.calibration, {})
        problems = config.problems()
        if problems:
            raise ValueError("; ".join(problems))
        from agents.specs import evaluator_from_spec

        evaluator_from_spec(config.evaluator)  # a bad evaluator fails here, before any floor
    except (ValueError, CaseError, OSError) as err:
        print(f"cmdp-plan: {err}", file=sys.stderr)
        return 2
    print(f"cmdp-plan: case {case.case.name!r}, objective {config.objective}: {config.trials} "
          f"plans x {len(config.search_seeds)} search seeds on the {floor.label()}, the best "
          f"{config.confirm} confirmed on {len(config.confirm_seeds)} held-out seeds on the "
          f"{config.confirm_fidelity} floor; " + workers_label(a.workers, a.ray), flush=True)
    note = floor.uncalibrated_note(a.case)
    if note:
        print(f"cmdp-plan: {note}", file=sys.stderr)
    try:
        result = search_plans(case, config, a.out, floor.calibration, a.case, a.workers, a.ray,
                              a.resume, not a.no_progress)
        write_outputs(result, case, trial_rows(a.out), a.out)
    except (ValueError, BackendError) as err:
        print(f"cmdp-plan: {err}", file=sys.stderr)
        return 2
    s = result.summary
    t, ch = s["tried"], s["chosen"]
    print(f"cmdp-plan: {t['trials']} plans tried ({t['complete']} on every search seed, "
          f"{t['pruned']} pruned, {t['refused']} refused by the case's checks; "
          f"{t['distinct_plans']} distinct) in {s['search']['wall_s']:.0f} s")
    if config.constrained:
        print(f"cmdp-plan: cost at most {config.max_cost_ratio:g} x the case's: "
              f"{t['feasible_complete']} plans feasible on every search seed, "
              f"{t['infeasible']} over the bound ({t['over_cost_early']} of them pruned early)")
    for p in s["confirmation"]["plans"]:
        h = p["held_out"]
        bound = ("" if "within_cost_bound" not in h else
                 "; within the cost bound" if h["within_cost_bound"] else "; OVER the cost bound")
        print(f"cmdp-plan: confirmed {p['plan']}: P80 {h['p80_s'] or 0:,.0f} s "
              f"({h['p80_ratio'] or 0:.3f} x), mean {h['makespan_ratio'] or 0:.3f} x, cost "
              f"{h['cost_mean'] or 0:,.0f}; vs the case {h['makespan_diff_mean_s'] or 0:+,.0f} "
              f"± {h['makespan_diff_ci95_s'] or 0:,.0f} s, cost {h['cost_diff_mean'] or 0:+,.0f} "
              f"± {h['cost_diff_ci95'] or 0:,.0f} ({h['paired_seeds']} held-out seeds){bound}")
    print(f"cmdp-plan: chosen: {ch['plan']}" + (f" ({ch['note']})" if ch["note"] else "")
          + f" -> {a.out / 'plan.toml'}; {s['wall_s']:.0f} s in all")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
