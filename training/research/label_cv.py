"""How much a student fitted to lookahead labels gains, measured on label floors it was not
fitted to (issue 32): seed-fold cross-validation of ``distill_fit.fit_weights``.

    python -m training.research.label_cv LABELS [LABELS ...] [--folds 5] [--fractions 0.25,0.5,1]
        [--features first|all|NAMES] [--pooled] [--mlp HIDDEN] [--base STUDENT [--prior]]
        [--out report.json]

The label floors are split by seed into ``--folds`` folds; for each fold the student is fitted
(gap-weighted, ``distill_fit.FIT_DEFAULTS``) on the others, or on the first ``fraction`` of their
seeds (a learning curve), and picks among each held-out decision's candidates. The measure is
the teacher's estimated makespan of the picked candidate minus that of Eq. 9's pick, averaged
over a floor's decisions, then over floors (mean and 95 % half-width over floors). The
estimates are noisy (the teacher's few futures), but the pick never saw them, so the
difference between two students is unbiased; the teacher's own best pick (``noisy best``,
printed for scale) is biased low by that noise.

``--pooled`` fits one weight vector for every crew type (what an untyped masked-choice model
can hold); ``--mlp H`` adds a small per-type network (tanh, H units) in place of the linear
residual (torch, full-batch Adam), to ask whether the labels hold more than a linear student
can take.

``--base STUDENT`` (a student file, ``agents/student.py``) measures every pick against that
student's pick instead of Eq. 9's: on labels of the student's own floors (``distill label
--acting student:FILE``) this is the question that matters, whether a refit would choose
better than the policy that made the states. ``--prior`` then fits the student as a residual
over the base student's scores (its penalty pulls towards the base's weights, not towards
Eq. 9): a refit that can only move away from the base where the labels say so.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch

from agents.student import StudentEvaluator
from cmdp_pymunk.events import write_atomic
from training.cli import OneLineParser
from training.research import distill_fit, distill_labels

CV_DEFAULTS = {"folds": 5, "fractions": (1.0,), "seed": 0}


def seed_folds(seeds: list[int], folds: int, seed: int = 0) -> list[np.ndarray]:
    """The label floors' seeds, shuffled with ``seed`` and split into ``folds`` parts."""
    order = np.array(sorted(set(seeds)))
    np.random.default_rng(seed).shuffle(order)
    return np.array_split(order, folds)


def rows_of(data: dict, rows: np.ndarray, pooled: bool = False) -> dict:
    """The label arrays restricted to ``rows``; ``pooled``: every row of one crew type, so
    ``fit_weights`` fits one vector."""
    n = len(data["choice"])
    out = {k: (v[rows] if isinstance(v, np.ndarray) and len(v) == n else v)
           for k, v in data.items()}
    if pooled:
        out["crew_type"] = np.full(int(rows.sum()), "all")
    return out


def linear_scorer(train: dict, pooled: bool):
    """The gap-weighted linear student; returns scores(test) -> V' + w_type . phi."""
    weights, _ = distill_fit.fit_weights(train, distill_fit.FIT_DEFAULTS["tau_s"],
                                         distill_fit.FIT_DEFAULTS["l2"], "gap")

    def scores(test: dict) -> np.ndarray:
        v0 = np.nan_to_num(test["values"])
        out = v0.copy()
        for crew_type, w in weights.items():
            rows = np.ones(len(v0), bool) if pooled else test["crew_type"] == crew_type
            out[rows] = v0[rows] + test["features"][rows] @ w
        return out
    return scores


def mlp_scorer(train: dict, hidden: int, epochs: int = 600, lr: float = 3e-3,
               weight_decay: float = 1e-3, seed: int = 0):
    """V' + net_type(phi), net_type a tanh network per crew type fitted by the same
    gap-weighted cross-entropy as the linear student (features standardised on ``train``)."""

    flat = train["features"].reshape(-1, train["features"].shape[2])
    mean, scale = flat.mean(0), flat.std(0) + 1e-6
    target = distill_fit.soft_targets(train["makespan_s"], distill_fit.FIT_DEFAULTS["tau_s"])
    nets = {}
    for crew_type in sorted(set(train["crew_type"])):
        rows = train["crew_type"] == crew_type
        torch.manual_seed(seed)
        x = torch.tensor((train["features"][rows] - mean) / scale, dtype=torch.float32)
        mask = torch.tensor(~np.isnan(train["values"][rows]))
        v = torch.tensor(np.nan_to_num(train["values"][rows]), dtype=torch.float32)
        p = torch.tensor(target[rows], dtype=torch.float32)
        w = torch.tensor(distill_fit.choice_weights(train["makespan_s"][rows]), dtype=torch.float32)
        net = torch.nn.Sequential(torch.nn.Linear(x.shape[2], hidden), torch.nn.Tanh(),
                                  torch.nn.Linear(hidden, 1))
        log_beta = torch.nn.Parameter(torch.tensor(float(np.log(5.0))))
        opt = torch.optim.Adam([*net.parameters(), log_beta], lr=lr, weight_decay=weight_decay)
        for _ in range(epochs):
            opt.zero_grad()
            logits = (log_beta.exp() * (v + net(x).squeeze(-1))).masked_fill(~mask, -1e9)
            logp = torch.log_softmax(logits, 1).masked_fill(~mask, 0.0)
            loss = (w * -(p * logp).sum(1)).mean()
            loss.backward()
            opt.step()
        nets[crew_type] = net

    def scores(test: dict) -> np.ndarray:
        out = np.nan_to_num(test["values"]).copy()
        for crew_type, net in nets.items():
            rows = test["crew_type"] == crew_type
            x = torch.tensor((test["features"][rows] - mean) / scale, dtype=torch.float32)
            with torch.no_grad():
                out[rows] += net(x).squeeze(-1).numpy()
        return out
    return scores


def picked_makespan(scores: np.ndarray, data: dict) -> np.ndarray:
    """The teacher's estimated makespan of each decision's pick (argmax over real
    candidates)."""
    mask = ~np.isnan(data["values"])
    pick = np.argmax(np.where(mask, scores, -np.inf), axis=1)
    return data["makespan_s"][np.arange(len(pick)), pick]


def base_scores(data: dict, path: str | Path) -> np.ndarray:
    """A student file's scores of the labels' candidates, V' + w_type . phi (its own features,
    taken from the labels' columns by name; a crew type it has no weights for scores V'),
    NaN where the candidate is padding. ValueError naming the file and the missing columns."""

    student = StudentEvaluator.load(path)
    have = list(data["feature_names"])
    missing = [n for n in student.features if n not in have]
    if missing:
        raise ValueError(f"--base {path}: its features {', '.join(missing)} are not in the "
                         f"labels ({', '.join(have)}); fix: relabel with --features all "
                         "(`distill relabel`)")
    phi = data["features"][..., [have.index(n) for n in student.features]]
    scores = np.array(data["values"], dtype=np.float64)
    for crew_type, w in student.weights.items():
        rows = data["crew_type"] == crew_type
        scores[rows] = scores[rows] + phi[rows] @ w
    return np.where(np.isnan(data["values"]), np.nan, scores)


def floor_gains(data: dict, folds: list[np.ndarray], make_scorer, fraction: float = 1.0,
                pooled: bool = False, reference: np.ndarray | None = None) -> dict[int, float]:
    """Per held-out label floor: mean over its decisions of (pick's estimated makespan -
    the reference's pick's), the student fitted on the other folds' first ``fraction`` of
    seeds. ``reference``: scores per candidate (``base_scores``); default V', Eq. 9."""
    gains = {}
    for k, fold in enumerate(folds):
        others = np.concatenate([f for j, f in enumerate(folds) if j != k])
        fitted_seeds = others[:max(1, int(round(fraction * len(others))))]
        train = rows_of(data, np.isin(data["row_seed"], fitted_seeds), pooled)
        on_fold = np.isin(data["row_seed"], fold)
        test = rows_of(data, on_fold)
        ref = np.nan_to_num(test["values"] if reference is None else reference[on_fold])
        base = picked_makespan(ref, test)
        student = picked_makespan(make_scorer(train)(test), test)
        for seed in fold:
            on = test["row_seed"] == seed
            gains[int(seed)] = float(np.mean(student[on] - base[on]))
    return gains


def summary(gains: dict[int, float]) -> dict:
    """Mean and 95 % half-width over floors."""
    g = np.array(list(gains.values()))
    half = 1.96 * g.std(ddof=1) / np.sqrt(len(g)) if len(g) > 1 else float("nan")
    return {"mean_s": round(float(g.mean()), 1), "ci95_s": round(float(half), 1),
            "floors": len(g)}


def noisy_best(data: dict, reference: np.ndarray | None = None) -> dict:
    """The teacher's own pick (the lowest estimate), against the reference's (Eq. 9's by
    default): biased low (module doc)."""
    m = np.where(np.isnan(data["makespan_s"]), np.inf, data["makespan_s"])
    eq9 = picked_makespan(np.nan_to_num(data["values"] if reference is None else reference),
                          data)
    diff = m.min(axis=1) - eq9
    return summary({int(s): float(np.mean(diff[data["row_seed"] == s]))
                    for s in sorted(set(data["row_seed"]))})


def main(argv: list[str] | None = None) -> int:

    argv = list(sys.argv[1:] if argv is None else argv)
    p = OneLineParser(prog="python -m training.research.label_cv",
                      description=__doc__.split("\n")[0])
    p.add_argument("labels", nargs="+", help="label folder(s) made by `distill label`")
    p.add_argument("--folds", type=int, default=CV_DEFAULTS["folds"])
    p.add_argument("--fractions", default="1",
                   help="shares of the training folds' seeds fitted on, e.g. 0.25,0.5,1")
    p.add_argument("--features", default="all",
                   help="first (the 11 FEATURE_NAMES), all (the labels' own) or names")
    p.add_argument("--pooled", action="store_true", help="one weight vector for every type")
    p.add_argument("--mlp", type=int, default=0, metavar="HIDDEN",
                   help="a per-type tanh network of HIDDEN units instead of the linear term")
    p.add_argument("--base", default="", metavar="STUDENT",
                   help="measure against this student file's pick, not Eq. 9's")
    p.add_argument("--prior", action="store_true",
                   help="fit a residual over --base's scores (penalty towards its weights)")
    p.add_argument("--seed", type=int, default=CV_DEFAULTS["seed"], help="fold shuffle")
    p.add_argument("--out", default="", help="also write the report (JSON) here")
    args = p.parse_args(argv)
    try:
        fractions = [float(x) for x in args.fractions.split(",")]
        if not all(0 < f <= 1 for f in fractions):
            raise ValueError
    except ValueError:
        p.error(f"--fractions {args.fractions!r}: give shares in (0, 1], e.g. 0.25,0.5,1")
    if args.prior and not args.base:
        p.error("--prior fits a residual over a student: give it with --base STUDENT")
    try:
        data = distill_labels.load_labels([Path(f) for f in args.labels])
        reference = base_scores(data, args.base) if args.base else None
        if args.features != "all":  # all: the labels' own columns
            data = distill_fit.select_features(data, distill_labels.features_option(args.features))
        if args.prior:  # the student's scores as V': the fit is a residual over them
            data = {**data, "values": reference}
        if args.folds < 2 or args.folds > len(set(data["row_seed"])):
            raise ValueError(f"--folds {args.folds}: give 2 to {len(set(data['row_seed']))} "
                             "(the label floors)")
    except ValueError as err:
        print(f"label_cv: {err}", file=sys.stderr)
        return 2
    wanted = list(data["feature_names"])
    folds = seed_folds(list(data["row_seed"]), args.folds, args.seed)
    if args.mlp:
        def make(train):
            return mlp_scorer(train, args.mlp, seed=args.seed)
    else:
        def make(train):
            return linear_scorer(train, args.pooled)
    kind = (f"mlp {args.mlp}" if args.mlp else "linear") + (", pooled" if args.pooled else
                                                             ", per type")
    if args.prior:
        kind += f", a residual over {args.base}"
    against = f"{args.base}'s pick" if args.base else "Eq. 9's pick"
    report = {"labels": args.labels, "decisions": int(len(data["choice"])),
              "floors": len(set(data["row_seed"])), "features": wanted, "student": kind,
              "folds": args.folds, "against": against,
              "noisy_best": noisy_best(data, reference), "curve": []}
    print(f"label_cv: {report['decisions']} decisions on {report['floors']} label floors, "
          f"{args.folds} folds by seed; student {kind} on {len(wanted)} features")
    for fraction in fractions:
        row = {"fraction": fraction, **summary(floor_gains(data, folds, make, fraction,
                                                           args.pooled, reference))}
        report["curve"].append(row)
        print(f"label_cv: fitted on {fraction:.0%} of the training seeds: pick - {against} "
              f"{row['mean_s']:+.1f} ± {row['ci95_s']:.1f} s a decision", flush=True)
    nb = report["noisy_best"]
    print(f"label_cv: the teacher's own noisy best, for scale: {nb['mean_s']:+.1f} ± "
          f"{nb['ci95_s']:.1f} s a decision (biased low)")
    if args.out:
        write_atomic(Path(args.out), json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
