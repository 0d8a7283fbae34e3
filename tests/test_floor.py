"""The built-in floor end to end (slow): seeds 0-9 under the priority heuristic and the
scripted navigator, and the same episode in two processes."""

import subprocess
import sys

import numpy as np
import pytest

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.evaluate import PriorityEvaluator

pytestmark = pytest.mark.slow
SINK_TOLERANCE_M = 0.35  # contact solving lets a disc overlap a component this much at most


def run_checked(seed: int):
    """One episode; asserts at every step that no crew is off the plane or sunk into a
    component. Returns the env."""
    env = cmdp_pymunk.parallel_env(seed=seed, evaluator=PriorityEvaluator(), park_idle=True)
    obs, _ = env.reset(seed=seed)
    nav = Navigator()
    rects = np.array([c.rect for c in env.engine.site.components])
    radii = np.array([c.spec.radius_m for c in env.engine.site.crews])
    half_w, half_h = env.case.plane.half_extents
    while env.agents:
        obs, *_ = env.step(env.agent_actions(nav, obs))
        on_plane = [c.status.name != "LEFT" for c in env.engine.site.crews]
        pos = np.array([b.position for b in env.engine.world.bodies])[on_plane]
        r = radii[on_plane]
        assert (np.abs(pos[:, 0]) <= half_w).all() and (np.abs(pos[:, 1]) <= half_h).all(), \
            f"t={env.engine.site.time_s}: a crew left the plane"
        dx = np.maximum(np.maximum(rects[None, :, 0] - pos[:, None, 0], 0),
                        pos[:, None, 0] - rects[None, :, 2])
        dy = np.maximum(np.maximum(rects[None, :, 1] - pos[:, None, 1], 0),
                        pos[:, None, 1] - rects[None, :, 3])
        depth = r[:, None] - np.hypot(dx, dy)
        assert depth.max() < SINK_TOLERANCE_M, \
            f"t={env.engine.site.time_s}: a crew sank {depth.max():.2f} m into a component"
    return env


def test_seeds_0_to_9_finish_every_task_in_the_papers_range():
    makespans = []
    for seed in range(10):
        env = run_checked(seed)
        site = env.engine.site
        assert site.done, f"seed {seed}: {site.tasks_ended}/87 tasks by the time limit"
        assert site.tasks_ended == 87
        makespans.append(env.makespan_s)
    mean = float(np.mean(makespans))
    assert 28000 <= mean <= 38000, makespans


SCRIPT = """
import cmdp_pymunk, hashlib
from agents.navigator import Navigator
from cmdp_pymunk.evaluate import PriorityEvaluator
env = cmdp_pymunk.parallel_env(seed=7, evaluator=PriorityEvaluator(), park_idle=True,
                               max_time_s=6000, position_log_every_s=5)
obs, _ = env.reset(seed=7)
nav = Navigator()
while env.agents:
    obs, *_ = env.step(env.agent_actions(nav, obs))
print(hashlib.sha256(env.log.to_csv().encode()).hexdigest())
"""


def test_same_seed_same_events_in_another_process():
    digests = set()
    for hash_seed in ("1", "2"):
        out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                             check=True, env={"PYTHONHASHSEED": hash_seed, "PATH": ""},
                             cwd=str(__import__("pathlib").Path(__file__).parent.parent))
        digests.add(out.stdout.strip())
    assert len(digests) == 1
