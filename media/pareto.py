"""The chart of a plan search (``cmdp-plan``, training/search/plan_search.py): every plan that
played all the search seeds as a point of P80 makespan against mean cost, the Pareto front of them
joined by a line, the case as written and the chosen plan marked. Rendered off-screen (Agg),
written whole (``write_atomic``)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from cmdp_pymunk.events import write_atomic

DPI = 110


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """The indices of the points no other point beats on both coordinates (lower is better;
    a point equal to another on both is kept once, the first), sorted by the first one."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1], i))
    front, best = [], float("inf")
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def draw_pareto(points: list[dict], path: Path, base: str, chosen: str,
                currency: str = "", title: str = "") -> Path:
    """``points``: dicts with ``plan``, ``p80_s`` and ``cost_mean`` (one per plan; the search
    seeds'); ``base`` and ``chosen`` name the case as written and the chosen plan."""
    import io

    fig = Figure(figsize=(7.0, 4.8))
    ax = fig.add_subplot()
    xy = [(p["p80_s"], p["cost_mean"]) for p in points]
    if xy:
        ax.scatter([x / 3600 for x, _ in xy], [y for _, y in xy], s=18, color="0.6",
                   label=f"plans on every search seed ({len(xy)})", zorder=2)
        front = pareto_front(xy)
        ax.plot([xy[i][0] / 3600 for i in front], [xy[i][1] for i in front], "-o",
                color="tab:blue", ms=5, label="Pareto front", zorder=3)
    for name, style, text in ((base, dict(marker="s", color="black"), "case as written"),
                              (chosen, dict(marker="*", color="tab:red", s=160),
                               "chosen plan")):
        mine = [p for p in points if p["plan"] == name]
        if mine and not (name == chosen and chosen == base):
            ax.scatter([mine[0]["p80_s"] / 3600], [mine[0]["cost_mean"]],
                       label=f"{text}: {name}"[:70], zorder=4, **style)
    ax.set_xlabel("P80 makespan on the search seeds (h)")
    ax.set_ylabel(f"mean cost ({currency})" if currency else "mean cost")
    ax.set_title(title or "Plans: P80 makespan against cost", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    write_atomic(path, buf.getvalue())
    return path
