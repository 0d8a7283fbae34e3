"""``cmdp-simulate``: simulate a whole floor without training, and look at the result.

    cmdp-simulate [--case FILE] [--evaluator priority|nearest|MODEL.zip]
                  [--navigator scripted|MODEL.zip] [--seed N] [--episodes N] [--out DIR] [--gif]

Writes into DIR: ``summary.json`` (makespan, tasks finished, per-crew reaching and idle steps
by cause, distance, material trips, crane waits, the makespan lower bound and the ratio to it,
seed, case, versions), ``events.csv`` (the event log), ``gantt_agents.png``, ``gantt_tasks.png``,
``trajectories.png``, with ``--gif`` ``rollout.gif``, and ``case.json`` (the resolved case).
With ``--episodes N`` each episode (seeds N0, N0 + 1, ...) gets its own ``seed-K/`` folder and
DIR gets ``makespans.csv`` and ``makespans.json`` (mean and spread).

An episode that stops making progress (no task moves on for ``--stall-s`` simulated seconds)
is stopped and reported with the crews and tasks involved; the command then exits with 1.
A bad case file exits with 2 and a message naming the file, the entry and the fix.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import cmdp_pymunk
from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from cmdp_pymunk.bounds import lower_bound
from cmdp_pymunk.decide import target_id
from cmdp_pymunk.evaluate import NearestFirstEvaluator
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.state import CrewStatus, IdleCause, Pool, activity

GIF_SECONDS = 30.0
GIF_FPS = 10
POSITION_LOG_EVERY_S = 5.0


@dataclass(frozen=True)
class SimulateArgs:
    """Arguments of ``cmdp-simulate`` (see the module doc)."""

    case: Path | None = None
    evaluator: str = "priority"
    navigator: str = "scripted"
    seed: int = 0
    episodes: int = 1
    out: Path = Path("out/simulate")
    gif: bool = False
    stall_s: float = 3600.0
    max_time_s: float | None = None
    charts: bool = True
    progress: bool = True
    stochastic: bool = False


def parse_args(argv: list[str] | None = None) -> SimulateArgs:
    p = argparse.ArgumentParser(prog="cmdp-simulate", description=__doc__.splitlines()[0])
    p.add_argument("--case", type=Path, default=None, help="case file (default: built-in)")
    p.add_argument("--evaluator", default="priority",
                   help="priority (Eq. 9), nearest, or a stage-2 model .zip (default: priority)")
    p.add_argument("--navigator", default="scripted",
                   help="scripted, or a stage-1 reaching model .zip (default: scripted)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--episodes", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("out/simulate"))
    p.add_argument("--gif", action="store_true", help="also write rollout.gif")
    p.add_argument("--stall-s", type=float, default=3600.0,
                   help="stop an episode in which no task moves on for this long (default 3600)")
    p.add_argument("--max-time-s", type=float, default=None,
                   help="time limit per episode (default: the case's)")
    p.add_argument("--no-charts", action="store_true", help="skip the PNG charts")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--stochastic", action="store_true",
                   help="a model navigator samples its actions (seeded per episode)")
    a = p.parse_args(argv)
    if a.episodes < 1:
        p.error("--episodes must be at least 1")
    if a.seed < 0:
        p.error(f"--seed must be 0 or more, not {a.seed}")
    if a.stall_s <= 0:
        p.error(f"--stall-s must be positive, not {a.stall_s:g}")
    if a.max_time_s is not None and a.max_time_s <= 0:
        p.error(f"--max-time-s must be positive, not {a.max_time_s:g}")
    return SimulateArgs(a.case, a.evaluator, a.navigator, a.seed, a.episodes, a.out, a.gif,
                        a.stall_s, a.max_time_s, not a.no_charts, not a.no_progress,
                        a.stochastic)


# -- policies -------------------------------------------------------------------------------

def make_evaluator(spec: str):
    if spec == "priority":
        return PriorityEvaluator()
    if spec == "nearest":
        return NearestFirstEvaluator()
    from agents.models import ModelEvaluator  # needs stable-baselines3

    return ModelEvaluator(_model_path(spec, "--evaluator"))


def make_navigator(spec: str, env, stochastic: bool = False):
    if spec == "scripted":
        return Navigator(env)
    from agents.models import PolicyNavigator

    return PolicyNavigator(_model_path(spec, "--navigator"), deterministic=not stochastic)


def _model_path(spec: str, option: str) -> Path:
    path = Path(spec)
    if not path.is_file():
        raise ValueError(f"{option} {spec!r}: no such model file; give a .zip saved by "
                         "stable-baselines3, or one of the built-in names")
    return path


# -- one episode ------------------------------------------------------------------------------

@dataclass
class Episode:
    seed: int
    makespan_s: float | None
    wall_s: float
    stalled: dict | None
    frames: list = field(default_factory=list)


def run_episode(env, navigator, seed: int, stall_s: float, progress: bool = True,
                frame_every_s: float | None = None) -> Episode:
    """Run one episode to its end, a time-out or a stall; frames every ``frame_every_s``."""
    from tqdm import tqdm

    observations, _ = env.reset(seed=seed)
    if hasattr(navigator, "reset"):
        navigator.reset(seed)
    site = env.site
    frames = []
    next_frame = 0.0
    last_progress = (0.0, -1.0)  # (time, total task progress)
    stalled = None
    bar = tqdm(total=int(env.max_time_s), unit="sim-s", disable=not progress, leave=False,
               mininterval=1.0, desc=f"seed {seed}")
    start = time.perf_counter()
    while env.agents:
        if frame_every_s is not None:
            while site.time_s >= next_frame:  # a jump repeats the still frame: even time-lapse
                frames.append(env.render())
                next_frame += frame_every_s
        before = site.time_s
        observations, *_ = env.step(navigator.actions(env, observations))
        bar.update(int(site.time_s - before))
        bar.set_postfix_str(f"tasks {site.tasks_ended}/{len(site.tasks)}", refresh=False)
        moved = sum(t.progress for t in site.tasks) + site.tasks_ended
        if moved != last_progress[1]:
            last_progress = (site.time_s, moved)
        elif site.time_s - last_progress[0] >= stall_s:
            stalled = stall_report(env, site.time_s - last_progress[0])
            break
    bar.close()
    if frame_every_s is not None:
        frames.append(env.render())
    return Episode(seed, env.makespan_s, time.perf_counter() - start, stalled, frames)


def stall_report(env, for_s: float) -> dict:
    """The crews and tasks involved in an episode that stopped making progress."""
    site = env.site
    crews = []
    for crew in site.crews:
        if crew.status == CrewStatus.LEFT:
            continue
        x, y = env.world.bodies[crew.index].position
        crews.append({"crew": crew.id, "activity": activity(crew),
                      "position_m": [round(x, 2), round(y, 2)],
                      "targets": sorted(target_id(site, t) for t in crew.scope),
                      "task": site.tasks[crew.task].id if crew.task >= 0 else None,
                      "steps_since_reach": crew.steps_since_reach})
    return {"after_s": for_s, "time_s": site.time_s, "crews": crews,
            "tasks_on": [t.id for t in site.tasks if t.pool == Pool.ON],
            "tasks_queued": [t.id for t in site.tasks if t.pool == Pool.QUEUE]}


# -- outputs ------------------------------------------------------------------------------------

def crew_summary(env) -> dict:
    out = {}
    for crew in env.site.crews:
        s = crew.stats
        out[crew.id] = {
            "type": crew.type,
            "reaching_steps": s.reaching_steps,
            "idle_steps": {"waiting_for_predecessor": s.idle_steps[IdleCause.PREDECESSOR],
                           "blocked_by_task_area": s.idle_steps[IdleCause.AREA],
                           "no_target": s.idle_steps[IdleCause.NO_TARGET]},
            "distance_m": round(s.distance_m, 2),
            "material_trips": s.material_trips,
            "crane_waits": s.crane_waits,
            "crane_wait_s": s.crane_wait_steps,
            "collisions": s.collisions,
            "congestion_entries": s.congestion_entries,
            "reaches": s.reaches,
            "reach_timeouts": s.reach_timeouts,
        }
    return out


def reach_rate(env) -> float:
    """Targets reached over attempts: an attempt that holds a target for the step cap
    (``reevaluate_after_steps``) without reaching counts as a miss each time."""
    reaches = sum(c.stats.reaches for c in env.site.crews)
    misses = sum(c.stats.reach_timeouts for c in env.site.crews)
    return reaches / max(1, reaches + misses)


def versions() -> dict:
    import gymnasium
    import pettingzoo
    import pymunk

    out = {"cmdp_pymunk": cmdp_pymunk.__version__, "python": platform.python_version(),
           "pymunk": pymunk.version, "numpy": np.__version__, "gymnasium": gymnasium.__version__,
           "pettingzoo": pettingzoo.__version__}
    try:
        out["commit"] = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5,
            cwd=Path(__file__).resolve().parent).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        out["commit"] = None
    return out


def summary(env, episode: Episode, args: SimulateArgs, case_label: str, lb) -> dict:
    site = env.site
    makespan = episode.makespan_s
    return {
        "case": site.case.case.name, "case_file": case_label, "seed": episode.seed,
        "stage": env.stage, "evaluator": args.evaluator, "navigator": args.navigator,
        "navigator_sampling": "stochastic" if args.stochastic else "deterministic",
        "makespan_s": makespan,
        "tasks_finished": site.tasks_ended, "tasks_total": len(site.tasks),
        "all_finished": site.done, "simulated_s": site.time_s,
        "lower_bound": lb.as_dict(),
        "makespan_over_lower_bound": makespan / lb.lower_bound_s if makespan else None,
        "reach_rate": reach_rate(env),
        "crews": crew_summary(env),
        "stalled": episode.stalled,
        "wall_s": round(episode.wall_s, 3),
        "simulated_s_per_wall_s": round(site.time_s / episode.wall_s, 1)
        if episode.wall_s > 0 else None,
        "versions": versions(),
    }


def write_json(path: Path, data) -> None:
    write_atomic(path, json.dumps(data, indent=2) + "\n")


def write_outputs(env, episode: Episode, folder: Path, args: SimulateArgs, case_label: str,
                  lb) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    data = summary(env, episode, args, case_label, lb)
    env.log.write_csv(folder / "events.csv")
    write_json(folder / "summary.json", data)
    if args.charts:
        from media.charts import draw_run

        draw_run(folder, env.case)
    if episode.frames:
        from media.charts import write_gif

        write_gif(episode.frames, folder / "rollout.gif", 1.0 / GIF_FPS)
    return data


def frame_interval(case, lb) -> float:
    """Simulated seconds between GIF frames, so the floor plays in GIF_SECONDS or less.

    Sized on three times the lower bound (heuristic makespans sit at about twice it); a longer
    episode is thinned out before writing.
    """
    return max(case.simulation.step_s, math.ceil(3 * lb.lower_bound_s / (GIF_SECONDS * GIF_FPS)))


def thin(frames: list, limit: int) -> list:
    if len(frames) <= limit:
        return frames
    keep = np.linspace(0, len(frames) - 1, limit).round().astype(int)
    return [frames[i] for i in keep]


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        case = cmdp_pymunk.load_case(args.case)
        evaluator = make_evaluator(args.evaluator)
    except cmdp_pymunk.CaseError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    case_label = str(args.case) if args.case else "built-in (precast_floor.toml)"
    lb = lower_bound(case)
    # The scripted navigator only parks idle crews: let the env skip their seconds (park_idle).
    # A trained navigator gets every crew's decision, as in the paper.
    env = cmdp_pymunk.parallel_env(case=case, stage=2, evaluator=evaluator,
                                   render_mode="rgb_array" if args.gif else None,
                                   max_time_s=args.max_time_s,
                                   position_log_every_s=POSITION_LOG_EVERY_S,
                                   park_idle=args.navigator == "scripted")
    try:
        if hasattr(evaluator, "bind"):
            evaluator.bind(env)
        navigator = make_navigator(args.navigator, env, args.stochastic)
        if hasattr(navigator, "bind"):
            navigator.bind(env)
    except ValueError as err:
        print(f"cmdp-simulate: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "case.json", case.model_dump(mode="json"))
    print(f"cmdp-simulate: case {case.case.name!r} ({len(case.crews)} crews, {len(case.tasks)} "
          f"tasks), lower bound {lb.lower_bound_s:.0f} s, evaluator {args.evaluator}, "
          f"navigator {args.navigator}")
    rows, failed = [], False
    for k in range(args.episodes):
        seed = args.seed + k
        folder = args.out if args.episodes == 1 else args.out / f"seed-{seed}"
        every = frame_interval(case, lb) if args.gif and k == 0 else None
        episode = run_episode(env, navigator, seed, args.stall_s, args.progress, every)
        episode.frames = thin(episode.frames, int(GIF_SECONDS * GIF_FPS))
        data = write_outputs(env, episode, folder, args, case_label, lb)
        rows.append(data)
        if episode.stalled:
            failed = True
            print(f"cmdp-simulate: seed {seed}: STALLED at t = {env.site.time_s:.0f} s after "
                  f"{episode.stalled['after_s']:.0f} s without progress:\n"
                  + json.dumps(episode.stalled, indent=2), file=sys.stderr)
        elif not env.site.done:
            failed = True
            print(f"cmdp-simulate: seed {seed}: time limit reached with "
                  f"{env.site.tasks_ended}/{len(case.tasks)} tasks finished", file=sys.stderr)
        else:
            print(f"cmdp-simulate: seed {seed}: makespan {episode.makespan_s:.0f} s "
                  f"({data['makespan_over_lower_bound']:.2f} x lower bound), "
                  f"{data['simulated_s_per_wall_s']:.0f} x real time -> {folder}")
    if args.episodes > 1:
        write_makespans(args.out, rows)
    if args.gif:
        gif = args.out if args.episodes == 1 else args.out / f"seed-{args.seed}"
        print(f"cmdp-simulate: GIF {gif / 'rollout.gif'}")
    print(f"cmdp-simulate: charts and summary in {args.out}")
    return 1 if failed else 0


def write_makespans(out: Path, rows: list[dict]) -> dict:
    lines = ["seed,makespan_s,makespan_over_lower_bound,tasks_finished,all_finished,reach_rate"]
    lines += [f"{r['seed']},{r['makespan_s'] or ''},{r['makespan_over_lower_bound'] or ''},"
              f"{r['tasks_finished']},{r['all_finished']},{r['reach_rate']:.4f}" for r in rows]
    write_atomic(out / "makespans.csv", "\n".join(lines) + "\n")
    done = [r["makespan_s"] for r in rows if r["makespan_s"]]
    stats = {"episodes": len(rows), "finished": len(done),
             "mean_s": float(np.mean(done)) if done else None,
             "std_s": float(np.std(done)) if done else None,
             "min_s": min(done, default=None), "max_s": max(done, default=None),
             "lower_bound_s": rows[0]["lower_bound"]["lower_bound_s"],
             "mean_over_lower_bound": float(np.mean(done)) / rows[0]["lower_bound"][
                 "lower_bound_s"] if done else None,
             "mean_reach_rate": float(np.mean([r["reach_rate"] for r in rows])),
             "makespans_s": [r["makespan_s"] for r in rows]}
    write_json(out / "makespans.json", stats)
    if done:
        print(f"cmdp-simulate: {len(done)}/{len(rows)} episodes finished; makespan mean "
              f"{stats['mean_s']:.0f} s, std {stats['std_s']:.0f} s, min {stats['min_s']:.0f}, "
              f"max {stats['max_s']:.0f} ({stats['mean_over_lower_bound']:.2f} x lower bound)")
    return stats


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
