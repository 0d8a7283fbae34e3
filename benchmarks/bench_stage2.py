"""Stage-2 decisions per second per core: the stage-2 env of a given commit (by default
c5777ae, the four layers ``TargetEvaluationEnv`` -> ``CMDPEnv`` -> ``Engine``) against this
checkout's (``decision_loop.DecisionLoop`` on the engine, and k floors in one ``FloorsVecEnv``), in
one process, with their ratio.

    python benchmarks/bench_stage2.py [--before c5777ae] [--decisions 30] [--k 4] [--rounds 3]

The old ``cmdp_pymunk`` package is taken from git (``git archive``) into a temporary folder
and imported under another name beside this one; the scripted navigator of this checkout
drives both (it reads the state, not the rays, through ``Engine.pose``: the old commit must
have it; c5777ae is fcdc414's four layers with it). Both are training floors as ``cmdp-train
stage2`` builds them (built-in case, idle crews parked, no rays, the global state after O^e
for the central critic) and both decide by the priority heuristic's first choice through Eq. 4,
so they play the very same decisions (the tests check it): a round plays the first
``--decisions`` of k floors, one after another (old, new) and side by side (the vector).
Rounds alternate (old, new, vector, old, ...) and each counts this process's CPU time:
decisions per CPU second is decisions per second per core, whatever else shares the
machine. The medians are printed, and the median of the rounds' new/old ratios. Target
(issue 16): 3x.
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import cmdp_pymunk  # noqa: E402
from agents.navigator import Navigator  # noqa: E402
from cmdp_pymunk.adapters.decision_loop import DecisionLoop  # noqa: E402
from cmdp_pymunk.evaluate import desired_position_of_first_choice  # noqa: E402


def old_package(commit: str, folder: Path):
    """``cmdp_pymunk`` as of ``commit``, imported as ``cmdp_pymunk_<commit>`` (its
    ``__init__`` left out: it would register the PettingZoo variants a second time)."""
    name = f"cmdp_pymunk_{commit}"
    archive = subprocess.run(["git", "archive", commit, "cmdp_pymunk"], cwd=ROOT, check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    (folder / "cmdp_pymunk").rename(folder / name)
    (folder / name / "__init__.py").write_text("")
    sys.path.insert(0, str(folder))
    return importlib.import_module(f"{name}.highlevel")


class OldPath:
    """The stage-2 training env before: ``TargetEvaluationEnv`` over ``CMDPEnv``, plus the
    global state (``Stage2Env`` with ``central_critic``)."""

    def __init__(self, highlevel):
        self.hl = highlevel.TargetEvaluationEnv(Navigator, park_idle=True, blind=True)

    def reset(self, seed: int) -> np.ndarray:
        obs, _ = self.hl.reset(seed=seed)
        return np.concatenate([obs, self.hl.env.state()])

    def teacher(self) -> np.ndarray:
        env = self.hl.env
        i, engine = env.agent_index[self.hl.deciding_agent], env.engine
        return np.array(desired_position_of_first_choice(engine.site.crews[i], engine.site,
                                                         engine.positions[i]), np.float32)

    def step(self, action) -> bool:
        obs, _, terminated, truncated, _ = self.hl.step(action)
        if not (terminated or truncated):
            np.concatenate([obs, self.hl.env.state()])
        return terminated or truncated


class NewPath:
    """This checkout's: ``DecisionLoop`` on the engine."""

    def __init__(self):
        self.floor = DecisionLoop(None, Navigator, park_idle=True, with_state=True)

    def reset(self, seed: int) -> np.ndarray:
        self.floor.reset(seed)
        return self.floor.observe()

    def teacher(self) -> np.ndarray:
        return self.floor.teacher_action()

    def step(self, action) -> bool:
        out = self.floor.decide(action)
        if not (out.terminated or out.truncated):
            self.floor.observe()
        return out.terminated or out.truncated


def decisions_per_cpu_s(path, k: int, decisions: int, seed: int) -> float:
    """Decisions per CPU second of ``decisions`` decisions from the start of each of k
    floors (seeds ``seed`` .. ``seed + k - 1``), one floor after another; resets counted."""
    cpu = time.process_time()
    for j in range(k):
        path.reset(seed + j)
        for _ in range(decisions):
            if path.step(path.teacher()):
                raise RuntimeError("an episode ended within the measured decisions; give "
                                   "fewer --decisions")
    return k * decisions / (time.process_time() - cpu)


def vector_per_cpu_s(k: int, decisions: int, seed: int) -> float:
    """The same decisions as ``decisions_per_cpu_s``, the k floors stepped side by side in
    one ``FloorsVecEnv`` (seeded ``seed`` + floor)."""
    from training.vec_env import FloorsVecEnv

    venv = FloorsVecEnv([lambda: DecisionLoop(None, Navigator, park_idle=True,
                                              with_state=True)] * k)
    cpu = time.process_time()
    venv.seed(seed)
    venv.reset()
    for _ in range(decisions):
        _, _, dones, _ = venv.step(np.stack([f.teacher_action() for f in venv.floors]))
        if dones.any():
            raise RuntimeError("an episode ended within the measured decisions; give fewer "
                               "--decisions")
    return k * decisions / (time.process_time() - cpu)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--before", default="c5777ae", help="the commit to compare against")
    parser.add_argument("--decisions", type=int, default=30,
                        help="decisions per floor and round (an episode has about 60)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--k", type=int, default=4, help="floors (seeds) per round")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        old_highlevel = old_package(args.before, Path(folder))
        old, new = OldPath(old_highlevel), NewPath()
        rates = {"old": [], "new": [], "vector": []}
        for r in range(args.rounds):
            rates["old"].append(decisions_per_cpu_s(old, args.k, args.decisions, args.seed))
            rates["new"].append(decisions_per_cpu_s(new, args.k, args.decisions, args.seed))
            rates["vector"].append(vector_per_cpu_s(args.k, args.decisions, args.seed))
            print(f"round {r + 1}: before {rates['old'][-1]:.1f}, floor {rates['new'][-1]:.1f}, "
                  f"{args.k} floors in a FloorsVecEnv {rates['vector'][-1]:.1f} decisions per "
                  "CPU second", flush=True)
    ratios = [n / o for n, o in zip(rates["new"], rates["old"], strict=True)]
    print(f"stage-2 decisions per second per core (median of {args.rounds} rounds; a round: "
          f"the first {args.decisions} heuristic decisions of seeds {args.seed}-"
          f"{args.seed + args.k - 1}):")
    print(f"  before ({args.before}, TargetEvaluationEnv -> CMDPEnv -> Engine): "
          f"{statistics.median(rates['old']):.1f}")
    print(f"  now (DecisionLoop on the Engine):                               "
          f"{statistics.median(rates['new']):.1f}")
    print(f"  now ({args.k} floors in one FloorsVecEnv):                    "
          f"{statistics.median(rates['vector']):.1f}")
    print(f"  ratio now / before: {statistics.median(ratios):.2f} x (target 3 x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
