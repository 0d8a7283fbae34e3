"""A short MaskablePPO fine-tune of a high-level model's lift head alone, on the event floor
(issue 42 item 6: one learning step from the written start, ``models/stage2_high_level.zip``).

    python -m training.research.lift_finetune --start models/stage2_high_level.zip \
        --seeds 3200-3299 --select 3100-3139 --floors 300 --out runs/lift-ft/model.zip

Each step of ``LiftEnv`` is one lift question of the floor (``DecisionLoop`` with
``logistics=True``): the observation is the model's own lift question (``CandidateView.
lift_question``), the mask allows the two answers only, the answer goes to the floor
(``DecisionLoop.lift``). Target choices between two lift questions are made by the model's
frozen target part (its ``CandidateModelEvaluator``, deterministic), never by PPO. The reward
is 0 but at a floor's end: ``-(M - M0) / scale_s``, M the floor's makespan and M0 the start's
deterministic makespan on the same seed (a shared-seed baseline, as ``docs/training-stage2.md``
found a PPO on this floor needs: the floor's own spread between seeds is larger than any
decision's effect). Only the lift head (``lift_linear``, ``lift_per_type``) and the critic
learn. At the end the fine-tuned model's deterministic floors are paired against the start's
on the ``--select`` seeds; the model is written (with ``NAME.finetune.json``: the command,
the seeds and the numbers) whether or not it moved, for the record.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium
import numpy as np
import torch
from gymnasium import spaces
from sb3_contrib import MaskablePPO
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import DummyVecEnv

import cmdp_pymunk
from agents.candidates import CandidateModelEvaluator
from agents.specs import make_navigator
from cmdp_pymunk.adapters.decision_loop import DecisionLoop
from cmdp_pymunk.eventfloor import calibration_for
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.rollout import run_episode
from training.cli import OneLineParser, seed_list
from training.runs.paired import paired
from training.runs.runner import make_engine


class LiftEnv(gymnasium.Env):
    """Lift questions of event floors on seeds drawn from ``seeds`` (see the module doc);
    ``evaluator``: the model whose target part chooses the targets and whose lift question
    is the observation; ``baseline_s``: the start's makespan per seed."""

    def __init__(self, evaluator: CandidateModelEvaluator, seeds: list[int],
                 baseline_s: dict[int, float], scale_s: float = 1000.0, rng_seed: int = 0):
        view, role = evaluator.view, evaluator.logistics
        self.evaluator, self.view, self.role = evaluator, view, role
        self.floor = DecisionLoop(cmdp_pymunk.load_case(None), fidelity="event",
                                  logistics=True, logistics_levels=role.shares)
        role.prepare(self.floor.case)
        self.seeds, self.baseline_s, self.scale_s = seeds, baseline_s, scale_s
        self.observation_space = spaces.Box(*_bounds(evaluator), dtype=np.float32)
        self.action_space = spaces.Discrete(view.cap + 2)
        self._rng = np.random.default_rng(rng_seed)
        self._seed = seeds[0]
        self.makespans: list[tuple[int, float | None]] = []

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._seed = int(self._rng.choice(self.seeds))
        self.floor.reset(self._seed)
        done = self._to_lift()
        if done:  # a floor without a lift question: nothing to learn from it; try another
            return self.reset()
        return self._observe(), {}

    def step(self, action):
        out = self.floor.lift(int(action) == self.view.cap + 1)
        done = out.terminated or out.truncated or self._to_lift()
        if not done:
            return self._observe(), 0.0, False, False, {}
        makespan = self.floor.engine.makespan_s
        self.makespans.append((self._seed, makespan))
        m = makespan if makespan is not None else 2.0 * self.baseline_s[self._seed]
        reward = -(m - self.baseline_s[self._seed]) / self.scale_s
        return np.zeros(self.observation_space.shape, np.float32), reward, True, False, {}

    def action_masks(self) -> np.ndarray:
        mask = np.zeros(self.view.cap + 2, bool)
        mask[self.view.cap:] = True
        return mask

    def _to_lift(self) -> bool:
        """Target choices by the frozen target part until the next lift question; True when
        the floor ends first."""
        floor = self.floor
        while floor.deciding_lift is None:
            if floor.deciding is None:
                return True
            out = floor.value_scope(self.evaluator.values_for(floor.engine, floor.deciding))
            if out.terminated or out.truncated:
                return True
        return False

    def _observe(self) -> np.ndarray:
        i, storage = self.floor.deciding_lift
        engine = self.floor.engine
        obs, _ = self.view.lift_question(engine.site.crews[i].type,
                                         self.role.feature_values(engine, i, storage))
        return obs


def _bounds(evaluator):
    space = evaluator.model.observation_space
    return space.low, space.high


def floors(evaluator: CandidateModelEvaluator, seeds: list[int]) -> list[dict]:
    """The model's deterministic event floors (both decisions its own), as bench rows."""
    case = cmdp_pymunk.load_case(None)
    engine = make_engine(case, evaluator, "scripted", fidelity="event",
                         calibration=calibration_for(case))
    navigator = make_navigator("scripted", engine, False)
    rows = []
    for seed in seeds:
        run_episode(engine, navigator, seed, 3600.0, progress=False)
        rows.append({"seed": seed, "finished": engine.site.done,
                     "makespan_s": engine.makespan_s})
    return rows


def freeze_all_but_lift(model) -> list[str]:
    """Only the lift head and the critic learn: the names of the parameters left trainable."""
    trainable = []
    for name, p in model.policy.named_parameters():
        # the actor is the scorer (action_net): of it only the lift head; the critic all
        learn = name.startswith("action_net.lift_") or not name.startswith("action_net.")
        p.requires_grad_(learn)
        if learn:
            trainable.append(name)
    return trainable


@dataclass
class Args:
    start: str
    seeds: list[int]
    select: list[int]
    floors: int
    out: Path
    n_steps: int
    learning_rate: float
    seed: int


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = OneLineParser(prog="python -m training.research.lift_finetune",
                      description=__doc__.split("\n")[0])
    p.add_argument("--start", default="models/stage2_high_level.zip")
    p.add_argument("--seeds", default="3200-3299", help="training seeds (event floors)")
    p.add_argument("--select", default="3100-3139", help="selection seeds, paired")
    p.add_argument("--floors", type=int, default=300, help="training floors (about)")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--n-steps", type=int, default=512)
    p.add_argument("--learning-rate", type=float, default=3e-3)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    args = Args(a.start, seed_list(a.seeds), seed_list(a.select), a.floors, a.out, a.n_steps,
                a.learning_rate, a.seed)
    torch.set_num_threads(1)
    start_cpu = time.process_time()
    start = CandidateModelEvaluator(args.start)
    if start.logistics is None:
        print(f"lift_finetune: {args.start} has no lift head; fix: a model written with "
              "distill student-model --lift", file=sys.stderr)
        return 2
    baseline = {r["seed"]: r["makespan_s"] for r in floors(start, args.seeds)}
    print(f"baselines: {len(baseline)} floors, mean {np.mean(list(baseline.values())):.0f} s "
          f"({time.process_time() - start_cpu:.0f} s CPU)", flush=True)
    set_random_seed(args.seed)
    learner = CandidateModelEvaluator(args.start)  # its own model: the start stays as it is
    env = LiftEnv(learner, args.seeds, baseline, rng_seed=args.seed)
    venv = DummyVecEnv([lambda: env])
    model = MaskablePPO.load(args.start, env=venv, device="cpu", n_steps=args.n_steps,
                             batch_size=args.n_steps // 4, n_epochs=4, gamma=1.0,
                             gae_lambda=1.0, learning_rate=args.learning_rate, ent_coef=0.0,
                             seed=args.seed)
    learner.model = model  # the env's target choices read the learning model (frozen part)
    trainable = freeze_all_but_lift(model)
    print(f"trainable: {', '.join(trainable)}", flush=True)
    questions = 0
    while len(env.makespans) < args.floors:
        model.learn(args.n_steps, reset_num_timesteps=False)
        questions += args.n_steps
        recent = env.makespans[-20:]
        diffs = [m - baseline[s] for s, m in recent if m is not None]
        print(f"{len(env.makespans)} floors, {questions} lift questions: last 20 floors "
              f"{np.mean(diffs):+.0f} s against the start ({time.process_time() - start_cpu:.0f}"
              f" s CPU)", flush=True)
    head = model.policy.action_net
    tuned, before = floors(learner, args.select), floors(start, args.select)
    vs = paired(tuned, before)
    report = {"command": "python -m training.research.lift_finetune " + " ".join(argv),
              "start": args.start, "training_seeds": [args.seeds[0], args.seeds[-1]],
              "training_floors": len(env.makespans), "lift_questions": questions,
              "selection_seeds": [args.select[0], args.select[-1]],
              "selection_vs_start_s": [round(vs["diff_mean_s"], 1), round(vs["diff_ci95_s"], 1)],
              "selection_mean_s": {"tuned": float(np.mean([r["makespan_s"] for r in tuned])),
                                   "start": float(np.mean([r["makespan_s"] for r in before]))},
              "lift_weights": head.lift_linear.weight.detach().flatten().tolist(),
              "lift_bias": float(head.lift_linear.bias.detach()),
              "cpu_s": round(time.process_time() - start_cpu, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.stem + ".tmp.zip")
    model.save(tmp)
    write_atomic(args.out.with_suffix(".finetune.json"), json.dumps(report, indent=1) + "\n")
    tmp.replace(args.out)
    print(f"selection seeds {args.select[0]}-{args.select[-1]}, tuned against the start: "
          f"{vs['diff_mean_s']:+.0f} ± {vs['diff_ci95_s']:.0f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
