"""Figs. 12-14 of section 5.3 from a comparison's per-episode rows: makespan, reaching steps and
space-constrained idle steps (idle because a task area blocked the crew's queued tasks) per
episode, one line per strategy. Written atomically, rendered off-screen (Agg)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from cmdp_pymunk.events import write_atomic

FIGURES = (
    ("fig12_makespan.png", "makespan_s", "makespan (s)", "Fig. 12: makespan per episode"),
    ("fig13_reaching_steps.png", "reaching_steps", "reaching steps (all crews)",
     "Fig. 13: reaching steps per episode"),
    ("fig14_idle_task_area.png", "idle_blocked_by_task_area",
     "space-constrained idle steps (all crews)",
     "Fig. 14: idle steps blocked by task areas per episode"),
)
DPI = 110


def _save(fig: Figure, path: Path) -> Path:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    write_atomic(path, buf.getvalue())
    return path


def per_episode_figure(rows: list[dict], key: str, ylabel: str, title: str,
                       path: Path) -> Path:
    """One line per (strategy, low level) over the seeds; unfinished episodes are marked with
    an x at the value they stopped with (makespan: the simulated time)."""
    fig = Figure(figsize=(8, 4.2))
    ax = fig.add_subplot()
    groups: dict[str, list[dict]] = {}
    navigators = {r["navigator"] for r in rows}
    for r in rows:
        label = r["strategy"] if len(navigators) == 1 else f"{r['strategy']} / {r['navigator']}"
        groups.setdefault(label, []).append(r)
    for label, group in groups.items():
        group = sorted(group, key=lambda r: r["seed"])
        seeds = [r["seed"] for r in group]
        values = [(r[key] if r[key] is not None else r["simulated_s"]) for r in group]
        (line,) = ax.plot(seeds, values, marker="o", markersize=3, linewidth=1.2, label=label)
        bad = [(s, v) for s, v, r in zip(seeds, values, group, strict=True) if not r["finished"]]
        if bad:
            ax.plot(*zip(*bad, strict=True), "x", color=line.get_color(), markersize=9)
    ax.set_xlabel("episode (seed)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def draw_comparison(rows: list[dict], folder: Path) -> list[Path]:
    """Figs. 12, 13 and 14 into ``folder``."""
    return [per_episode_figure(rows, key, ylabel, title, Path(folder) / name)
            for name, key, ylabel, title in FIGURES]
