"""Rounds of approximate policy iteration: the student labels its own states with the
lookahead, is refitted, and becomes the next round's base (issue 32, item 4).

    python -m training.research.policy_iteration [--rounds 2] [--start models/searched_rule.json]
        [--teacher candidates=3+futures=16+race=4+floor=event] [--label-seeds 0-23]
        [--select-seeds 140-159] [--features first|all|NAMES] [--candidates 3] [--tau-s 300]
        [--l2 1]
        [--aggregate | --no-aggregate] [--workers 1] [--case FILE] [--out runs/policy_iteration]

Round r (1, 2, ...) starts from a base: ``--start`` in round 1 (a student JSON, e.g. the
searched rule, or ``priority``: Eq. 9), the previous round's student after. It

1. labels its slice of ``--label-seeds`` (split evenly over the rounds, in order: each round
   meets fresh states) with ``training.research.distill``'s DAgger mode: the floor follows the
   base (``--acting student:BASE``) and the lookahead ``lookahead:TEACHER+base=student:BASE``
   (by default the racing event-floor lookahead) labels each decision on those states;
2. fits the new student (``agents.student``: Eq. 9's V' plus w_type . phi over Eq. 9's best
   ``--candidates``) to the labels (with ``--aggregate``, the default, the labels of every
   round so far, as DAgger does) by cross-entropy weighted by how much each choice matters
   (``distill_fit.choice_weights``: the gap between the candidates' estimated makespans);
3. plays Eq. 9, the base and the new student on ``--select-seeds`` on the pymunk floor with
   the scripted navigator (as ``cmdp-evaluate`` does, ``training.runs``) and compares them on
   the same seeds (paired differences to Eq. 9 with Student's t 95 % intervals,
   ``training.runs.paired``).

Writes into OUT: ``settings.json`` (the options; a rerun must give the same ones);
per round ``round-r/labels/seed-N.npz``, ``round-r/student.json`` (the weights, and the
command, the rounds, the label seeds, the teacher and the fit's report),
``round-r/episodes.jsonl`` (the selection episodes as they end), ``round-r/summary.md``
(``cmdp-evaluate``'s table) and ``round-r/report.json``; and ``rounds.md``, a line per
finished round: its label seeds and decisions; on its own labels (its base's states) how
often the teacher's pick (the lowest estimated makespan) is Eq. 9's, the base's and the new
student's, and the regret of each (the teacher's estimated seconds lost a decision by its
pick instead of the teacher's: a gap-weighted error); and base - Eq. 9 and student - Eq. 9 on
the selection seeds (mean, 95 % half-width, ratio of means).

Every file is written whole (atomically). Rerun the same command to resume: a round with a
``report.json`` is skipped, label floors with a file are kept, the fit (cheap, deterministic:
L-BFGS from a fixed start) is redone, and kept selection episodes are reused while the refit
gives the same weights. Ctrl-C says what is kept, exit status 130; bad options (a missing
start file, bad teacher options, label seeds among the selection seeds or the report seeds
100-139 and 200-239) exit 2 before any floor runs. The same options and seeds give the same
weights: each label floor is seeded by its seed, the lookahead's futures by its decisions.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

import cmdp_pymunk
from agents.features import POLICY_ITERATION_FEATURES
from agents.specs import evaluator_from_spec
from agents.student import StudentEvaluator
from cmdp_pymunk.bounds import lower_bound
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.interrupt import sigint_guard
from training.cli import OneLineParser, positive_int, positive_seconds, seed_list
from training.research import distill_fit, distill_labels, distill_model
from training.runs.backends import BackendError, open_backend
from training.runs.paired import markdown_table, summarize
from training.runs.strategies import episode_job, read_log

REPORT_SEEDS = tuple(range(100, 140)) + tuple(range(200, 240))  # the results' seeds: never
# trained on (docs/results.md)
DEFAULT_TEACHER = "candidates=3+futures=16+race=4+floor=event"
NAVIGATOR = "scripted"


@dataclass(frozen=True)
class IterationArgs:
    """The options (module doc); ``start`` is ``priority`` or a student JSON path."""

    rounds: int = 2
    start: str = "models/searched_rule.json"
    teacher: str = DEFAULT_TEACHER
    label_seeds: tuple[int, ...] = tuple(range(24))
    select_seeds: tuple[int, ...] = tuple(range(140, 160))
    features: tuple[str, ...] = POLICY_ITERATION_FEATURES
    candidates: int = 3
    tau_s: float = distill_fit.FIT_DEFAULTS["tau_s"]
    l2: float = distill_fit.FIT_DEFAULTS["l2"]
    aggregate: bool = True
    workers: int = 1
    case: str | None = None
    out: Path = Path("runs/policy_iteration")
    argv: tuple[str, ...] = ()

    def settings(self) -> dict:
        """What a rerun in the same OUT must repeat (``workers`` may change)."""
        return {k: v for k, v in json.loads(json.dumps(asdict(self), default=str)).items()
                if k not in ("workers", "out", "argv")}


@dataclass(frozen=True)
class Round:
    """One round's plan: its number (from 1), base spec, label seeds and folder."""

    number: int
    base: str  # an evaluator spec: priority or student:PATH
    seeds: tuple[int, ...]
    folder: Path

    @property
    def labels(self) -> Path:
        return self.folder / "labels"

    @property
    def student(self) -> Path:
        return self.folder / "student.json"

    @property
    def report(self) -> Path:
        return self.folder / "report.json"

    @property
    def episodes(self) -> Path:
        return self.folder / "episodes.jsonl"

    def teacher(self, options: str) -> str:
        """The labelling lookahead's options: the teacher's, over this round's base."""
        return f"{options}+base={self.base}"


def seed_slices(seeds: tuple[int, ...], rounds: int) -> list[tuple[int, ...]]:
    """``seeds`` in order, cut into ``rounds`` consecutive slices as even as can be (sizes
    differ by one at most, the first ones larger)."""
    return [tuple(int(s) for s in part) for part in np.array_split(np.array(seeds), rounds)]


def plan_rounds(args: IterationArgs) -> list[Round]:
    """Every round's plan; round r's base is round r-1's student (paths absolute, so the
    teacher each label file names is the same from any working folder)."""
    out = Path(args.out).resolve()
    start = "priority" if args.start == "priority" else \
        f"student:{Path(args.start.removeprefix('student:')).resolve()}"
    rounds, base = [], start
    for r, seeds in enumerate(seed_slices(args.label_seeds, args.rounds), start=1):
        rounds.append(Round(r, base, seeds, out / f"round-{r}"))
        base = f"student:{rounds[-1].student}"
    return rounds


# -- checks, before any floor ---------------------------------------------------------------

def check(args: IterationArgs):
    """Every option, before any floor runs: the case, the start, the teacher, the features,
    the seeds, and OUT's earlier settings. The case; ValueError naming the option and the fix."""

    if args.rounds < 1:
        raise ValueError(f"--rounds {args.rounds}: give 1 or more")
    if args.candidates < 2:
        raise ValueError(f"--candidates {args.candidates}: the student re-ranks Eq. 9's best "
                         "k targets; give 2 or more (default 3)")
    case = cmdp_pymunk.load_case(args.case)
    if "base=" in args.teacher:
        raise ValueError(f"--teacher {args.teacher!r}: leave base= out; each round's base is "
                         "the previous round's student (round 1's: --start)")
    distill_labels.teacher_options(f"{args.teacher}+base=priority")
    if args.start != "priority":
        path = Path(args.start.removeprefix("student:"))
        if not path.is_file():
            raise ValueError(f"--start {args.start}: no such file; fix: give a student JSON "
                             "(e.g. models/searched_rule.json, or a round's student.json) or "
                             "priority")
        evaluator_from_spec(f"student:{path}")  # a file that is no student fails here
    check_seeds(args)
    check_earlier_run(args)
    return case


def check_seeds(args: IterationArgs) -> None:
    """Label seeds: enough for the rounds, none among the selection or the report seeds."""
    if len(args.label_seeds) < args.rounds:
        raise ValueError(f"--label-seeds: {len(args.label_seeds)} seed(s) for {args.rounds} "
                         "rounds; fix: give at least one a round")
    for name, other in (("--select-seeds", set(args.select_seeds)),
                        ("the report seeds 100-139 and 200-239", set(REPORT_SEEDS))):
        both = sorted(set(args.label_seeds) & other)
        if both:
            raise ValueError(f"--label-seeds overlap {name} ({_seed_text(both)}): a student "
                             "selected or reported on its own training floors flatters "
                             "itself; fix: label on other seeds (e.g. 0-23)")


def _seed_text(seeds: list[int]) -> str:
    return ", ".join(map(str, seeds[:5])) + (", ..." if len(seeds) > 5 else "")


def check_earlier_run(args: IterationArgs) -> None:
    """A rerun in an OUT with ``settings.json`` resumes only with the same settings, and the
    label files kept there must be this run's (the same teacher and features)."""
    saved = Path(args.out) / "settings.json"
    if saved.is_file():
        before = json.loads(saved.read_text())
        changed = sorted(k for k, v in args.settings().items() if before.get(k) != v)
        if changed:
            raise ValueError(f"--out {args.out}: the run there used other settings "
                             f"({', '.join(changed)}); fix: run again with the same options to "
                             "resume it, or give a new --out")
    for plan in plan_rounds(args):
        for f in distill_labels.label_files(plan.labels):
            data = np.load(f)
            teacher = f"lookahead:{plan.teacher(args.teacher)}"
            names = tuple(str(n) for n in data["feature_names"]) \
                if "feature_names" in data else None
            if str(data["teacher"]) != teacher or names != args.features:
                raise ValueError(f"{f}: labelled by {data['teacher']} with other features or "
                                 f"teacher than this run's ({teacher}); fix: give a new --out, "
                                 f"or remove {plan.labels}")


# -- one round ------------------------------------------------------------------------------

def label_round(args: IterationArgs, plan: Round, bar) -> None:
    """The round's label floors not labelled yet: the base acts, the teacher labels; each
    ``seed-N.npz`` written as its floor ends (``distill_labels.save_labels``)."""

    plan.labels.mkdir(parents=True, exist_ok=True)
    todo = [s for s in plan.seeds if not (plan.labels / f"seed-{s}.npz").exists()]
    jobs = [(args.case, s, None, None, plan.base, False, plan.teacher(args.teacher),
             args.features) for s in todo]
    with open_backend(distill_labels._label_job, None, args.workers) as pool:
        for _, result in pool.as_completed(jobs):
            distill_labels.save_labels(plan.labels / f"seed-{result['seed']}.npz", result)
            bar.update(1)
            bar.write(f"policy_iteration: round {plan.number}: seed {result['seed']}: "
                      f"{len(result['rows'])} decisions, {result['overrides']} where the "
                      f"teacher differs from the base, makespan {result['makespan_s']} s, "
                      f"{result['wall_s']:.0f} s")


def fit_round(args: IterationArgs, plans: list[Round], plan: Round) -> tuple[dict, dict]:
    """The new student: fitted with the gap-weighted loss to this round's labels (with
    ``aggregate``, to every round's so far), written to ``student.json``; a kept student with
    other weights makes the kept selection episodes stale (they are dropped). Returns the
    labels fitted and the fit's report."""

    folders = [p.labels for p in plans[:plan.number]] if args.aggregate else [plan.labels]
    data = distill_labels.load_labels(folders)
    start = time.perf_counter()
    weights, report = distill_fit.fit_weights(data, args.tau_s, args.l2, weights="gap")
    student = StudentEvaluator({k: v.tolist() for k, v in weights.items()},
                               candidates=args.candidates, features=data["feature_names"])
    meta = {"command": "python -m training.research.policy_iteration " + " ".join(args.argv),
            "round": plan.number, "rounds": args.rounds, "base": plan.base,
            "label_seeds": list(plan.seeds), "fitted_on_seeds": data["seeds"],
            "teacher": f"lookahead:{plan.teacher(args.teacher)}", "acting": plan.base,
            "aggregate": args.aggregate, "tau_s": args.tau_s, "l2": args.l2,
            "fit_weighting": "gap", "fit_wall_s": round(time.perf_counter() - start, 2),
            "fit": report}
    if not plan.student.is_file() or _weights(plan.student) != _weights_of(student):
        # the kept student episodes (if any) played other weights: Eq. 9's and the base's stay

        spec = f"student:{plan.student}"
        write_atomic(plan.episodes, "".join(json.dumps(r) + "\n" for r in read_log(plan.episodes)
                                            if r["strategy"] != spec))
    student.save(plan.student, meta)
    return data, report


def _weights(path: Path) -> dict:
    return json.loads(path.read_text())["weights"]


def _weights_of(student) -> dict:
    return {k: [round(float(x), 6) for x in v] for k, v in student.weights.items()}


def evaluate_round(args: IterationArgs, case, plan: Round, bar) -> list[dict]:
    """Eq. 9, the base and the new student on the selection seeds (pymunk floor, scripted
    navigator, ``cmdp-evaluate``'s episodes); each row appended to ``episodes.jsonl`` as it
    ends, the kept ones reused."""

    specs = selection_strategies(plan)
    kept = {(r["strategy"], r["seed"]): r for r in read_log(plan.episodes)}
    # the kept rows only (a line cut by a killed run is dropped), then the new ones appended
    write_atomic(plan.episodes, "".join(json.dumps(r) + "\n" for r in kept.values()))
    wanted = [(s, seed) for s in specs for seed in args.select_seeds]
    todo = [k for k in wanted if k not in kept]
    bar.update(len(wanted) - len(todo))
    runner_args = (case, 3600.0, None, False, None, "pymunk", None)
    with plan.episodes.open("a") as log, \
            open_backend(episode_job, runner_args, args.workers) as pool:
        for i, row in pool.as_completed([(s, NAVIGATOR, seed) for s, seed in todo]):
            spec, seed = todo[i]
            row = {"strategy": spec, "navigator": NAVIGATOR, "seed": seed,
                   "fidelity": "pymunk", **row}
            log.write(json.dumps(row) + "\n")
            log.flush()
            kept[(spec, seed)] = row
            bar.update(1)
    return [kept[k] for k in wanted]


def selection_strategies(plan: Round) -> list[str]:
    """Eq. 9 (the reference), the base (unless it is Eq. 9) and the new student."""
    return list(dict.fromkeys(["priority", plan.base, f"student:{plan.student}"]))


def label_scores(data: dict, weights: dict) -> dict[str, np.ndarray]:
    """Per policy, a score per label row and candidate whose argmax is its pick: Eq. 9 (V'),
    the base (the first candidate: the teacher ranks candidates by its base), the new student
    (V' + w_type . phi); -inf on padded candidates."""
    v = data["values"]
    mask = ~np.isnan(v)
    v0 = np.where(mask, v, 0.0)
    residual = np.zeros_like(v0)
    for crew_type, w in weights.items():
        rows = data["crew_type"] == crew_type
        residual[rows] = data["features"][rows] @ np.asarray(w)
    first = np.zeros_like(v0)
    first[:, 0] = 1.0
    return {name: np.where(mask, s, -np.inf)
            for name, s in (("eq9", v0), ("base", first), ("student", v0 + residual))}


def round_report(args: IterationArgs, plan: Round, fitted: dict, fit_report: dict,
                 summary: list[dict], wall_s: float) -> dict:
    """The round's numbers (module doc): its labels, agreement and regret on them, and the
    paired comparison on the selection seeds (``summary``: ``training.runs.paired.summarize``
    of its episodes)."""
    own = distill_labels.load_labels(plan.labels)
    mask = ~np.isnan(own["values"])
    target = distill_fit.soft_targets(own["makespan_s"], args.tau_s)
    weights = json.loads(plan.student.read_text())["weights"]
    scores = label_scores(own, weights)
    lowest = np.argmax(target, axis=1)
    by_spec = {e["strategy"]: e for e in summary}
    student_spec = f"student:{plan.student}"

    def versus(spec: str) -> dict:
        e = by_spec[spec]
        return {"spec": spec, "makespan_mean_s": e["makespan_mean_s"],
                "makespan_ci95_s": e["makespan_ci95_s"], "finished": e["finished"],
                "episodes": e["episodes"], "diff_vs_eq9_mean_s": e["vs_priority_diff_mean_s"],
                "diff_vs_eq9_ci95_s": e["vs_priority_diff_ci95_s"],
                "ratio_vs_eq9": e["vs_priority_ratio"],
                "paired_seeds": e["vs_priority_paired_seeds"]}

    return {
        "round": plan.number, "rounds": args.rounds, "base": plan.base,
        "student": str(plan.student), "teacher": f"lookahead:{plan.teacher(args.teacher)}",
        "label_seeds": list(plan.seeds), "decisions": int(len(own["choice"])),
        "fitted_on_seeds": fitted["seeds"], "fitted_decisions": int(len(fitted["choice"])),
        "features": list(own["feature_names"]), "aggregate": args.aggregate,
        # on this round's labels (the base's own states; the student was fitted on them)
        "agreement": {k: round(distill_model.choice_agreement(s, mask, target), 3)
                      for k, s in scores.items()},
        "regret_s": {k: round(distill_model.choice_regret_s(s, mask, own["makespan_s"]), 1)
                     for k, s in scores.items()},
        # racing: the teacher's pick among the survivors is not always the lowest mean
        "teacher_choice_not_lowest_mean": int(np.sum(own["choice"] != lowest)),
        "label_wall_s": round(float(np.sum(own["label_wall_s"])), 1),
        "fit": fit_report, "select_seeds": list(args.select_seeds),
        "eq9": versus("priority"), "base_vs_eq9": versus(plan.base),
        "student_vs_eq9": versus(student_spec), "wall_s": round(wall_s, 1),
    }


def rounds_table(reports: list[dict]) -> str:
    """``rounds.md``: a line per finished round (module doc)."""

    def diff(e: dict) -> str:
        if e["diff_vs_eq9_mean_s"] is None:
            return "-"
        half = e["diff_vs_eq9_ci95_s"]
        return (f"{e['diff_vs_eq9_mean_s']:+,.0f} ± {half:,.0f} s ({e['ratio_vs_eq9']:.3f})"
                if half is not None else f"{e['diff_vs_eq9_mean_s']:+,.0f} s "
                f"({e['ratio_vs_eq9']:.3f})")

    lines = ["# Rounds of approximate policy iteration", "",
             "Teacher agreement and regret (s a decision) on the round's own labels (its base's "
             "states), as Eq. 9 / base / student; paired differences to Eq. 9 on the selection "
             "seeds (pymunk floor): mean ± 95 % half-width (ratio of means).", "",
             "| round | label seeds | decisions (fitted) | agreement | regret s | "
             "base - Eq. 9 | student - Eq. 9 |", "|---|---|---|---|---|---|---|"]
    for r in reports:
        seeds = r["label_seeds"]
        span = f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) \
            else ",".join(map(str, seeds))
        a, g = r["agreement"], r["regret_s"]
        lines.append(f"| {r['round']} | {span} | {r['decisions']} ({r['fitted_decisions']}) | "
                     f"{a['eq9']:.0%} / {a['base']:.0%} / {a['student']:.0%} | "
                     f"{g['eq9']:.0f} / {g['base']:.0f} / {g['student']:.0f} | "
                     f"{diff(r['base_vs_eq9'])} | {diff(r['student_vs_eq9'])} |")
    return "\n".join(lines) + "\n"


# -- the run --------------------------------------------------------------------------------

def run(args: IterationArgs) -> int:
    """Check everything, then the rounds not reported yet (module doc)."""


    case = check(args)
    bound_s = lower_bound(case).lower_bound_s
    plans = plan_rounds(args)
    write_atomic(Path(args.out) / "settings.json", json.dumps(args.settings(), indent=1) + "\n")
    done = [p for p in plans if p.report.is_file()]
    per_round = [len(p.seeds) + len(args.select_seeds) * len(selection_strategies(p))
                 for p in plans]
    initial = sum(n for p, n in zip(plans, per_round, strict=True) if p in done) + sum(
        len(distill_labels.label_files(p.labels)) for p in plans if p not in done)
    print(f"policy_iteration: {args.rounds} round(s) from {plans[0].base}, teacher "
          f"lookahead:{args.teacher}+base=<the round's base>, label seeds "
          f"{' | '.join(_span(p.seeds) for p in plans)}, selection seeds "
          f"{_span(args.select_seeds)}, {args.workers} worker(s); "
          f"{len(done)} round(s) already reported in {args.out}", flush=True)
    with tqdm(total=sum(per_round), initial=initial, unit="floor", desc="policy iteration",
              file=sys.stderr) as bar:
        for plan in plans:
            if plan in done:
                bar.write(f"policy_iteration: round {plan.number}: reported in {plan.report}; "
                          "skipped")
                continue
            start = time.perf_counter()
            label_round(args, plan, bar)
            fitted, fit_report = fit_round(args, plans, plan)
            summary = summarize(evaluate_round(args, case, plan, bar), bound_s, None)
            report = round_report(args, plan, fitted, fit_report, summary,
                                  time.perf_counter() - start)
            write_atomic(plan.folder / "summary.md", markdown_table(summary, bound_s, None))
            write_atomic(plan.report, json.dumps(report, indent=1) + "\n")
            reports = [json.loads(p.report.read_text()) for p in plans if p.report.is_file()]
            write_atomic(Path(args.out) / "rounds.md", rounds_table(reports))
            bar.write(rounds_table([report]).splitlines()[-1])
    print(f"policy_iteration: {args.rounds} round(s) in {args.out}; the last student: "
          f"{plans[-1].student}; the table: {Path(args.out) / 'rounds.md'}")
    return 0


def _span(seeds) -> str:
    seeds = list(seeds)
    return f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) \
        else ",".join(map(str, seeds))


def kept_text(args: IterationArgs) -> str:
    """What a stopped run keeps, for the Ctrl-C line."""
    parts = []
    for plan in plan_rounds(args):
        if plan.report.is_file():
            parts.append(f"round {plan.number} reported")
            continue
        labelled = len(distill_labels.label_files(plan.labels))
        if labelled:

            episodes = len(read_log(plan.episodes))
            parts.append(f"round {plan.number}: {labelled} of {len(plan.seeds)} label floors"
                         + (f", {episodes} selection episodes" if episodes else ""))
    return "; ".join(parts) or "nothing yet"


def parse_args(argv: list[str]) -> IterationArgs:


    def features(text: str) -> tuple[str, ...]:
        try:
            return distill_labels.features_option(text)
        except ValueError as err:
            raise argparse.ArgumentTypeError(
                str(err).removeprefix(f"--features {text!r}: ")) from None

    p = OneLineParser(prog="python -m training.research.policy_iteration",
                      description=__doc__.split("\n")[0])
    d = IterationArgs()
    p.add_argument("--rounds", type=positive_int, default=d.rounds,
                   help=f"rounds of label, fit, evaluate (default {d.rounds})")
    p.add_argument("--start", default=d.start,
                   help=f"round 1's base: a student JSON or priority (default {d.start})")
    p.add_argument("--teacher", default=d.teacher,
                   help="the labelling lookahead's options, without base= (each round's base "
                        f"is added; default {d.teacher})")
    p.add_argument("--label-seeds", type=seed_list, default=list(d.label_seeds),
                   help="training seeds, split evenly over the rounds in order (default 0-23)")
    p.add_argument("--select-seeds", type=seed_list, default=list(d.select_seeds),
                   help="seeds on which each round's base and student meet Eq. 9 (default "
                        "140-159)")
    p.add_argument("--features", type=features, default=POLICY_ITERATION_FEATURES,
                   help="the student's features (default: the first eleven and the four "
                        "binding ones), first (the 11 FEATURE_NAMES), all (ALL_FEATURES, with "
                        "the state features) or names joined by commas")
    p.add_argument("--candidates", type=positive_int, default=d.candidates,
                   help=f"the student re-ranks Eq. 9's best k targets (default {d.candidates})")
    p.add_argument("--tau-s", type=positive_seconds, default=d.tau_s,
                   help="temperature of the teacher's soft choice, in seconds of makespan "
                        f"(default {d.tau_s:g})")
    p.add_argument("--l2", type=float, default=d.l2, help=f"weight penalty (default {d.l2:g})")
    p.add_argument("--aggregate", action=argparse.BooleanOptionalAction,
                   default=d.aggregate,
                   help="fit on the labels of every round so far, as DAgger (default), or on "
                        "the round's own (--no-aggregate)")
    p.add_argument("--workers", type=positive_int, default=d.workers,
                   help="worker processes for the label floors and the selection episodes "
                        "(default 1)")
    p.add_argument("--case", default=None, help="case file (default: built-in)")
    p.add_argument("--out", type=Path, default=d.out, help=f"run folder (resumes; default "
                   f"{d.out})")
    a = p.parse_args(argv)
    return IterationArgs(a.rounds, a.start, a.teacher, tuple(a.label_seeds),
                         tuple(a.select_seeds), tuple(a.features), a.candidates, a.tau_s, a.l2,
                         a.aggregate, a.workers, a.case, a.out, tuple(argv))


def main(argv: list[str] | None = None) -> int:

    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    try:
        with sigint_guard():
            return run(args)
    except (ValueError, BackendError) as err:
        print(f"policy_iteration: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\npolicy_iteration: interrupted; kept in {args.out}: {kept_text(args)} (every "
              "file whole); run the same command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
