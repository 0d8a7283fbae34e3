"""Distil the lookahead into a cheap evaluator: label decisions, then fit a residual over Eq. 9.

    python -m training.distill label --seeds 0-19 --out runs/labels [--futures 0] [--workers 2]
                                     [--ray [ADDRESS]]
    python -m training.distill fit runs/labels --out models/student_priority.json

``label`` runs the lookahead (``agents.lookahead``) on each seed's floor and keeps, for every
decision with two or more candidates, the candidates' features (``agents.features``), their
Eq. 9 values, the lookahead's makespan per candidate and its choice: one ``seed-N.npz`` per
floor, written whole as soon as its floor is done, so a stopped run resumes where it stopped
(seeds with a file are skipped). The floors run in worker processes, or on Ray actors with
``--ray`` (docs/ray.md). ``fit`` fits the student (``agents.student``): per crew type a
weight vector w so that softmax(beta * (V' + w . phi)) over a decision's candidates matches
the teacher's soft choice (softmax of minus the makespans over ``tau_s``), with an L2
penalty; every weight 0 is Eq. 9 itself. The JSON it writes names the command, the label
folder and the seeds.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

FIT_DEFAULTS = {"tau_s": 300.0, "l2": 1.0}


# -- labels -------------------------------------------------------------------------------------

def label_floor(case_path: str | None, seed: int, candidates: int, futures: int) -> dict:
    """One floor under the lookahead: its makespan and the arrays of its decisions."""
    import cmdp_pymunk
    from agents.features import FloorFacts, candidate_features
    from agents.lookahead import LookaheadEvaluator, LookaheadSettings
    from agents.specs import make_navigator
    from cmdp_pymunk.evaluate import PriorityEvaluator

    case = cmdp_pymunk.load_case(case_path)
    lookahead = LookaheadEvaluator(settings=LookaheadSettings(candidates, futures))
    env = cmdp_pymunk.parallel_env(case=case, evaluator=lookahead, park_idle=True, blind=True,
                                   stall_s=3600.0)
    lookahead.bind(env)
    navigator = make_navigator("scripted", env)
    rows: list[tuple] = []
    priority = PriorityEvaluator()
    facts: list = []

    def record(engine, i, values, decision) -> None:
        site = engine.site
        if not facts:
            facts.append(FloorFacts.of(site))
        crew = site.crews[i]
        priorities = priority.priorities(crew, site, engine.positions[i])
        phi = candidate_features(facts[0], crew, site, engine.positions[i],
                                 decision.candidates, priorities, engine.positions)
        rows.append((crew.type, [priorities[t] for t in decision.candidates], phi,
                     decision.makespans_s, decision.candidates.index(decision.choice)))

    lookahead.on_decision = record
    start = time.perf_counter()
    env.reset(seed=seed)
    navigator.reset(seed)
    while env.agents:
        env.step(navigator.actions(env, None))
    return {"seed": seed, "makespan_s": env.makespan_s, "rows": rows,
            "wall_s": time.perf_counter() - start, "overrides": lookahead.summary()["overrides"]}


def save_labels(path: Path, result: dict, candidates: int) -> None:
    rows = result["rows"]
    n, k = len(rows), candidates
    from agents.features import FEATURE_NAMES

    v = np.full((n, k), np.nan)
    phi = np.zeros((n, k, len(FEATURE_NAMES)))
    makespan = np.full((n, k), np.nan)
    for r, (_, values, features, makespans, _) in enumerate(rows):
        m = len(values)
        v[r, :m], phi[r, :m], makespan[r, :m] = values, features, makespans
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez_compressed(tmp, crew_type=np.array([r[0] for r in rows], dtype="U8"), values=v,
                        features=phi, makespan_s=makespan,
                        choice=np.array([r[4] for r in rows], dtype=np.int64),
                        seed=result["seed"], floor_makespan_s=result["makespan_s"] or np.nan,
                        wall_s=result["wall_s"])
    tmp.replace(path)


def _label_job(runner, case_path, seed, candidates, futures):
    return label_floor(case_path, seed, candidates, futures)


def label(args) -> int:
    from tqdm import tqdm

    from agents.episodes import open_backend
    from training.evaluate import seed_list

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [s for s in seed_list(args.seeds) if not (out / f"seed-{s}.npz").exists()]
    print(f"label: {len(seed_list(args.seeds)) - len(seeds)} seeds already labelled in {out}; "
          f"{len(seeds)} to go (candidates {args.candidates}, futures {args.futures}, "
          f"{args.workers} worker(s))", flush=True)
    jobs = [(args.case, s, args.candidates, args.futures) for s in seeds]
    # Floors in worker processes, or on Ray actors (--ray): each file is written here as its
    # floor arrives, so a stopped run keeps every finished floor.
    with tqdm(total=len(jobs), unit="floor", desc="label", file=sys.stderr) as bar, \
            open_backend(_label_job, None, args.workers or None, args.ray) as pool:
        for _, result in pool.as_completed(jobs):
            _report(out, result, args.candidates, bar)
    return 0


def _report(out: Path, result: dict, candidates: int, bar) -> None:
    save_labels(out / f"seed-{result['seed']}.npz", result, candidates)
    bar.update(1)
    bar.write(f"label: seed {result['seed']}: makespan {result['makespan_s']} s, "
              f"{len(result['rows'])} decisions, {result['overrides']} overrides, "
              f"{result['wall_s']:.0f} s")


# -- fit ----------------------------------------------------------------------------------------

def load_labels(folder: Path) -> dict:
    files = sorted(Path(folder).glob("seed-*.npz"), key=lambda p: int(p.stem.split("-")[1]))
    if not files:
        raise ValueError(f"{folder}: no seed-N.npz label files; make them with "
                         f"`python -m training.distill label --out {folder}`")
    parts = [np.load(f) for f in files]
    return {"crew_type": np.concatenate([p["crew_type"] for p in parts]),
            "values": np.concatenate([p["values"] for p in parts]),
            "features": np.concatenate([p["features"] for p in parts]),
            "makespan_s": np.concatenate([p["makespan_s"] for p in parts]),
            "seeds": [int(p["seed"]) for p in parts],
            "label_wall_s": [float(p["wall_s"]) for p in parts]}


def soft_targets(makespan_s: np.ndarray, tau_s: float) -> np.ndarray:
    """The teacher's choice as probabilities: softmax(-(M - min M) / tau) over candidates
    (NaN-padded candidates get 0)."""
    m = np.where(np.isnan(makespan_s), np.inf, makespan_s)
    z = -(m - m.min(axis=1, keepdims=True)) / tau_s
    p = np.exp(z)
    return p / p.sum(axis=1, keepdims=True)


def fit_weights(data: dict, tau_s: float, l2: float) -> tuple[dict[str, np.ndarray], dict]:
    """Per crew type, w and beta minimising cross-entropy to the soft targets + l2 |w|^2."""
    from scipy.optimize import minimize

    out, report = {}, {}
    target = soft_targets(data["makespan_s"], tau_s)
    for crew_type in sorted(set(data["crew_type"])):
        rows = data["crew_type"] == crew_type
        v, phi, p = data["values"][rows], data["features"][rows], target[rows]
        mask = ~np.isnan(v)
        v0 = np.where(mask, v, 0.0)
        nf = phi.shape[2]

        def loss(x, v0=v0, phi=phi, p=p, mask=mask):
            beta, w = np.exp(x[0]), x[1:]
            logits = np.where(mask, beta * (v0 + phi @ w), -np.inf)
            top = logits.max(axis=1, keepdims=True)
            logp = logits - top - np.log(np.exp(logits - top).sum(axis=1, keepdims=True))
            ce = -np.sum(p * np.where(mask, logp, 0.0)) / len(v0)  # padded: p = 0
            return ce + l2 * float(w @ w) / len(v0)

        x0 = np.zeros(1 + nf)
        x0[0] = np.log(5.0)  # beta: V' differences of about 0.2 give odds of about e
        res = minimize(loss, x0, method="L-BFGS-B")
        w = res.x[1:]
        base_choice = np.argmax(np.where(mask, v0, -np.inf), axis=1)
        student_choice = np.argmax(np.where(mask, v0 + phi @ w, -np.inf), axis=1)
        teacher = np.argmax(p, axis=1)
        out[str(crew_type)] = w
        report[str(crew_type)] = {
            "decisions": int(rows.sum()), "beta": round(float(np.exp(res.x[0])), 3),
            "agree_base_teacher": round(float(np.mean(base_choice == teacher)), 3),
            "agree_student_teacher": round(float(np.mean(student_choice == teacher)), 3),
            "loss_zero_weights": round(float(loss(np.r_[res.x[0], np.zeros(nf)])), 4),
            "loss": round(float(res.fun), 4)}
    return out, report


def fit(args) -> int:
    from agents.student import StudentEvaluator

    data = load_labels(Path(args.labels))
    weights, report = fit_weights(data, args.tau_s, args.l2)
    student = StudentEvaluator({k: v.tolist() for k, v in weights.items()},
                               candidates=data["values"].shape[1])
    meta = {"command": "python -m training.distill " + " ".join(args.argv),
            "labels": str(args.labels), "label_seeds": data["seeds"],
            "label_wall_s_per_floor": round(float(np.mean(data["label_wall_s"])), 1),
            "tau_s": args.tau_s, "l2": args.l2, "fit": report}
    student.save(Path(args.out), meta)
    for crew_type, r in report.items():
        print(f"fit: {crew_type}: {r['decisions']} decisions, teacher agrees with Eq. 9 on "
              f"{r['agree_base_teacher']:.0%}, with the student on "
              f"{r['agree_student_teacher']:.0%} (loss {r['loss_zero_weights']} -> {r['loss']})")
    print(f"fit: wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    from agents.episodes import BackendError
    from training.cli import OneLineParser, add_ray_option

    argv = list(sys.argv[1:] if argv is None else argv)
    parser = OneLineParser(prog="python -m training.distill", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("label", help="label decisions with the lookahead, one file per seed")
    p.add_argument("--case", default=None, help="case file (default: built-in)")
    p.add_argument("--seeds", default="0-19", help="training seeds, e.g. 0-19")
    p.add_argument("--candidates", type=int, default=3, help="top-k of Eq. 9 tried")
    p.add_argument("--futures", type=int, default=0,
                   help="sampled futures per candidate (0: the floor's own durations)")
    p.add_argument("--workers", type=int, default=1,
                   help="worker processes, or Ray actors with --ray (0 with --ray ADDRESS: one "
                        "per CPU of the cluster)")
    add_ray_option(p)
    p.add_argument("--out", default="runs/labels", help="label folder (resumes)")
    f = sub.add_parser("fit", help="fit the student to a label folder")
    f.add_argument("labels", help="label folder made by `label`")
    f.add_argument("--out", default="models/student_priority.json")
    f.add_argument("--tau-s", type=float, default=FIT_DEFAULTS["tau_s"],
                   help="temperature of the teacher's soft choice, in seconds of makespan")
    f.add_argument("--l2", type=float, default=FIT_DEFAULTS["l2"], help="weight penalty")
    args = parser.parse_args(argv)
    args.argv = argv
    try:
        return label(args) if args.command == "label" else fit(args)
    except (ValueError, BackendError) as err:
        print(f"distill: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ndistill: interrupted; finished seeds are kept (run again to resume)",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
