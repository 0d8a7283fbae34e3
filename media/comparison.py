"""Figs. 12-14 of section 5.3 from a comparison's per-episode rows: makespan, reaching steps and
space-constrained idle steps (idle because a task area blocked the crew's queued tasks).

By default each figure is a box and strip plot, one column per strategy (and low level): every
episode a dot, the box its quartiles, and a diamond with an error bar for the mean and its 95 %
interval (``training.runs.paired.summarize``'s); the makespan figure draws the lower bound and,
when it was solved, CP-SAT's bound as dashed lines. Episodes that did not finish are drawn as
an x at the value they stopped with (makespan: the simulated time) and left out of the box.
``per_seed=True`` draws the paper's style instead: one line per strategy over the seeds, with
whole-number seed ticks and a break wherever the seeds are not consecutive (seeds 0-9 and
100-104 are two runs of a line, not one). Written atomically, rendered off-screen (Agg).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.timeuse import CATEGORY_WORDS

FIGURES = (
    ("fig12_makespan.png", "makespan_s", "makespan (s)", "Fig. 12: makespan"),
    ("fig13_reaching_steps.png", "reaching_steps", "reaching steps (all crews)",
     "Fig. 13: reaching steps"),
    ("fig14_idle_task_area.png", "idle_blocked_by_task_area",
     "space-constrained idle steps (all crews)", "Fig. 14: idle steps blocked by task areas"),
)
# summarize()'s mean and interval of each figure's value
SUMMARY_KEYS = {"makespan_s": ("makespan_mean_s", "makespan_ci95_s"),
                "reaching_steps": ("reaching_steps_mean", "reaching_steps_ci95"),
                "idle_blocked_by_task_area": ("idle_blocked_by_task_area_mean",
                                              "idle_blocked_by_task_area_ci95")}
DPI = 110


def _save(fig: Figure, path: Path) -> Path:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    write_atomic(path, buf.getvalue())
    return path


def _groups(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """Rows by (strategy, low level), in the order they first appear, each sorted by seed."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["strategy"], r["navigator"]), []).append(r)
    return {k: sorted(g, key=lambda r: r["seed"]) for k, g in groups.items()}


def _label(key: tuple[str, str], navigators: set) -> str:
    return key[0] if len(navigators) == 1 else f"{key[0]} / {key[1]}"


def _value(r: dict, key: str) -> float:
    return r[key] if r[key] is not None else r["simulated_s"]


def consecutive_runs(seeds: list[int]) -> list[slice]:
    """Index ranges of ``seeds`` (sorted) that are consecutive whole numbers: where a per-seed
    line may join its points. [0, 1, 2, 7, 8] -> [slice(0, 3), slice(3, 5)]."""
    runs, start = [], 0
    for i in range(1, len(seeds) + 1):
        if i == len(seeds) or seeds[i] != seeds[i - 1] + 1:
            runs.append(slice(start, i))
            start = i
    return runs


def _error_bar(entry: dict, mean_key: str, ci_key: str) -> list[list[float]]:
    """The mean's 95 % interval as matplotlib's (below, above) error: a count's interval is
    clipped at 0 (``training.runs.paired.count_interval``: ``{key}_ci95_low``)."""
    mean, half = entry[mean_key], entry.get(ci_key) or 0.0
    low = entry.get(ci_key + "_low")
    below = mean - low if low is not None else half
    return [[below], [half]]


def strip_offsets(n: int, width: float = 0.28) -> np.ndarray:
    """Horizontal offsets that spread n dots evenly across a column (deterministic, no
    random jitter): 0 for one dot, -width..width for several."""
    return np.zeros(n) if n <= 1 else np.linspace(-width, width, n)


def strategy_figure(rows: list[dict], key: str, ylabel: str, title: str, path: Path,
                    summary: list[dict] | None = None, bounds: dict | None = None) -> Path:
    """``strategy_plot`` written to ``path``."""
    return _save(strategy_plot(rows, key, ylabel, title, summary, bounds), path)


def strategy_plot(rows: list[dict], key: str, ylabel: str, title: str,
                  summary: list[dict] | None = None, bounds: dict | None = None) -> Figure:
    """One column per (strategy, low level): episodes as dots, their quartiles as a box, the
    mean with its 95 % interval (from ``summary``, the entries of
    ``training.runs.paired.summarize``; none drawn without it), and ``bounds`` (label ->
    seconds, e.g. the lower bound and CP-SAT's) as dashed lines."""
    groups = _groups(rows)
    navigators = {r["navigator"] for r in rows}
    stats = {(e["strategy"], e["navigator"]): e for e in summary or []}
    mean_key, ci_key = SUMMARY_KEYS.get(key, (None, None))
    fig = Figure(figsize=(max(5.5, 1.5 * len(groups) + 2.5), 4.6))
    ax = fig.add_subplot()
    handles = []
    for i, (gkey, group) in enumerate(groups.items()):
        done = [_value(r, key) for r in group if r["finished"]]
        if done:
            ax.boxplot([done], positions=[i], widths=0.6, showfliers=False,
                       medianprops={"color": "#444444"}, boxprops={"color": "#888888"},
                       whiskerprops={"color": "#888888"}, capprops={"color": "#888888"})
        xs = i + strip_offsets(len(group))
        colour = f"C{i % 10}"
        for x, r in zip(xs, group, strict=True):
            ax.plot(x, _value(r, key), "o" if r["finished"] else "x", color=colour,
                    markersize=4 if r["finished"] else 8, alpha=0.75)
        e = stats.get(gkey)
        if e is not None and mean_key and e.get(mean_key) is not None:
            ax.errorbar(i + 0.42, e[mean_key], yerr=_error_bar(e, mean_key, ci_key), fmt="D",
                        color="black", markersize=5, capsize=4, linewidth=1.2)
    if stats:
        handles.append(Line2D([], [], marker="D", color="black", linestyle="-",
                              label="mean ± 95 % interval"))
    if any(not r["finished"] for r in rows):
        handles.append(Line2D([], [], marker="x", color="grey", linestyle="",
                              label="did not finish (value when stopped)"))
    for j, (name, value) in enumerate((bounds or {}).items()):
        if value is not None:
            style = ("--", ":")[j % 2]
            ax.axhline(value, color="#555555", linestyle=style, linewidth=1)
            handles.append(Line2D([], [], color="#555555", linestyle=style,
                                  label=f"{name} {value:,.0f}"))
    tilt = len(groups) > 3
    ax.set_xticks(range(len(groups)), [_label(k, navigators) for k in groups],
                  rotation=15 if tilt else 0, ha="right" if tilt else "center")
    ax.set_xlim(-0.6, len(groups) - 0.4)
    n_seeds = len({r["seed"] for r in rows})
    ax.set_ylabel(ylabel)
    ax.set_title(f"{title} ({n_seeds} seeds; dots: episodes, box: quartiles)", fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    if handles:
        ax.legend(handles=handles, fontsize=8)
    fig.tight_layout()
    return fig


def per_episode_figure(rows: list[dict], key: str, ylabel: str, title: str,
                       path: Path) -> Path:
    """``per_episode_plot`` written to ``path``."""
    return _save(per_episode_plot(rows, key, ylabel, title), path)


def per_episode_plot(rows: list[dict], key: str, ylabel: str, title: str) -> Figure:
    """The paper's style: one line per (strategy, low level) over the seeds, joined only
    between consecutive seeds, whole-number ticks; unfinished episodes marked with an x at
    the value they stopped with (makespan: the simulated time)."""
    fig = Figure(figsize=(8, 4.2))
    ax = fig.add_subplot()
    navigators = {r["navigator"] for r in rows}
    for i, (gkey, group) in enumerate(_groups(rows).items()):
        seeds = [r["seed"] for r in group]
        values = [_value(r, key) for r in group]
        colour = f"C{i % 10}"
        for k, run in enumerate(consecutive_runs(seeds)):
            ax.plot(seeds[run], values[run], marker="o", markersize=3, linewidth=1.2,
                    color=colour, label=_label(gkey, navigators) if k == 0 else None)
        bad = [(s, v) for s, v, r in zip(seeds, values, group, strict=True) if not r["finished"]]
        if bad:
            ax.plot(*zip(*bad, strict=True), "x", color=colour, markersize=9)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("episode (seed)")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{title} per episode")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def draw_comparison(rows: list[dict], folder: Path, summary: list[dict] | None = None,
                    lower_bound_s: float | None = None, cpsat_bound_s: float | None = None,
                    per_seed: bool = False) -> list[Path]:
    """Figs. 12, 13 and 14 into ``folder``: box and strip plots with the means, intervals and
    (Fig. 12) bounds, or with ``per_seed`` the paper's lines over the seeds."""
    bounds = {"lower bound": lower_bound_s, "CP-SAT bound": cpsat_bound_s}
    out = []
    for name, key, ylabel, title in FIGURES:
        path = Path(folder) / name
        if per_seed:
            out.append(per_episode_figure(rows, key, ylabel, title, path))
        else:
            out.append(strategy_figure(rows, key, ylabel, title, path, summary,
                                       bounds if key == "makespan_s" else None))
    return out




def draw_time_use(entries: list[dict], path: Path) -> Path:
    """Where the time goes: for each strategy and crew type a horizontal bar of its mean
    crew-hours per floor, stacked by category (``training.runs.paired.time_use_summary``, the
    whole floor); written atomically."""
    from cmdp_pymunk.timeuse import CATEGORIES

    floor = [e for e in entries if e["phase"] == "floor"]
    keys = list(dict.fromkeys((e["strategy"], e["navigator"], e["crew_type"]) for e in floor))
    hours = {(e["strategy"], e["navigator"], e["crew_type"], e["category"]):
             (e["mean_s"] or 0.0) / 3600 for e in floor}
    multi = len({k[1] for k in keys}) > 1
    labels = [f"{s}{' / ' + n if multi else ''}: {ct}" for s, n, ct in keys]
    fig = Figure(figsize=(10.0, max(2.6, 1.2 + 0.32 * len(keys))))
    ax = fig.add_subplot()
    left = np.zeros(len(keys))
    for k, category in enumerate(CATEGORIES):
        width = np.array([hours[(*key, category)] for key in keys])
        ax.barh(range(len(keys)), width, left=left, color=f"C{k % 10}",
                label=CATEGORY_WORDS.get(category, category))
        left += width
    ax.set_yticks(range(len(keys)), labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("crew-hours per floor (mean over the episodes)")
    ax.set_title("Where the time goes, by crew type")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    return _save(fig, path)
