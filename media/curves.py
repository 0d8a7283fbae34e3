"""Training curves (Fig. 5) from the CSV log that SB3 writes beside its TensorBoard logs."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from cmdp_pymunk.events import write_atomic

CURVES = (
    ("rollout/ep_rew_mean", "mean episode reward (per crew)"),
    ("cmdp/reach_rate", "reach rate (rollouts)"),
    ("eval/reach_rate", "reach rate (evaluation, fixed seeds)"),
    ("cmdp/steps_per_reach", "steps per reach"),
)


def read_progress(path: Path) -> dict[str, list[tuple[float, float]]]:
    """Columns of SB3's progress.csv as (timesteps, value) series, empty cells skipped."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    if not rows or "time/total_timesteps" not in rows[0]:
        raise ValueError(f"{path}: no time/total_timesteps column; is it SB3's progress.csv?")
    series: dict[str, list[tuple[float, float]]] = {}
    for row in rows:
        step = row.get("time/total_timesteps")
        if not step:
            continue
        for key, value in row.items():
            if value not in ("", None) and key != "time/total_timesteps":
                try:
                    series.setdefault(key, []).append((float(step), float(value)))
                except ValueError:
                    pass
    return series


STAGE2_CURVES = (
    ("rollout/ep_rew_mean", "mean episode reward R_e (team)"),
    ("cmdp/makespan_s", "makespan, s (rollouts)"),
    ("eval/mean_makespan_s", "makespan, s (evaluation, fixed seeds)"),
    ("cmdp/idle_steps_area", "idle crew-steps: task area blocked"),
)


def draw_training_curve(progress_csv, path: Path, title: str = "Stage 1: "
                        "target-reaching policy", curves=CURVES, scale: float = 1e6,
                        xlabel: str = "training steps (millions of agent-steps)") -> Path:
    """Fig. 5 (stage 1) or Fig. 7 (stage 2): ``curves`` ((column, label) pairs) against
    training steps over ``scale``; written atomically.

    ``progress_csv`` is one CSV or a list of them (a run and its resumed parts)."""
    from matplotlib.figure import Figure

    parts = [progress_csv] if isinstance(progress_csv, (str, Path)) else list(progress_csv)
    if not parts:
        raise FileNotFoundError("no progress*.csv to draw")
    series: dict[str, list[tuple[float, float]]] = {}
    for part in parts:
        for key, points in read_progress(Path(part)).items():
            series.setdefault(key, []).extend(points)
    for points in series.values():
        points.sort()
    panels = [(k, label) for k, label in curves if k in series]
    if not panels:
        raise ValueError(f"{progress_csv}: none of {', '.join(k for k, _ in curves)} logged")
    fig = Figure(figsize=(6.5, 2.4 * len(panels)), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (key, label) in zip(axes, panels, strict=True):
        xs, ys = zip(*series[key], strict=True)
        ax.plot([x / scale for x in xs], ys, marker="." if len(xs) < 30 else None)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(title)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    write_atomic(Path(path), buf.getvalue())
    return Path(path)


def draw_stage2_curve(progress_csv, path: Path) -> Path:
    """Fig. 7: the target-evaluation policy's reward and makespan against decisions."""
    return draw_training_curve(progress_csv, path, "Stage 2: target-evaluation policy",
                               STAGE2_CURVES, 1e3, "training steps (thousands of decisions)")
