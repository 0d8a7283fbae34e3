"""A run's charts, drawn into its folder from its event log (section 5.2, Figs. 9, 10 and 11).

:func:`draw_run` draws Fig. 9 (``media.gantt.gantt_agents``), Fig. 10
(``media.gantt.gantt_tasks``), the resource profile (``media.gantt.resource_profile``) and
Fig. 11 (``media.layout_views.trajectories``) into a run folder (``CHART_FILES``). A run on the
event floor (``summary.json``'s ``fidelity``, docs/event-floor.md) says so in the Gantt charts'
titles and gets no trajectories: its crews are where the floor has them at events only, not
along their walks.

How the run ended (``media.timeline.RunEnd``) comes from the run folder's ``summary.json``
(``all_finished``, ``stalled``, ``simulated_s``; :func:`read_summary`) and the case's number of
tasks.

Where the rest went (each module says why it is apart):

- ``media.timeline``: the event log read into intervals, counts and paths (no matplotlib);
- ``media.gantt``: Figs. 9 and 10 and the resource profile;
- ``media.layout_views``: Fig. 11's trajectories and the stall picture;
- ``media.figures``: a figure written as a PNG, the date axis;
- ``media.gif``: the GIF writer.

The charts' public names are still importable from here (``__all__``), as the docs and
examples named them ``media.charts.X`` before.

Command line: ``python -m media.charts RUN_DIR [--case PATH]`` redraws a saved run's charts;
without ``--case`` it uses the ``case.json`` that ``cmdp-simulate`` saves with a run (in RUN_DIR
or its parent), else the built-in case.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cmdp_pymunk.cases.load import Case
from cmdp_pymunk.events import read_csv
from media.gantt import (
    gantt_agents,
    gantt_agents_figure,
    gantt_tasks,
    gantt_tasks_figure,
    resource_profile,
    resource_profile_figure,
)
from media.gif import GifStream, write_gif
from media.layout_views import stall_picture, trajectories
from media.timeline import RunEnd, activity_intervals, run_end, unknown_tasks

__all__ = [
    "CHART_FILES", "draw_run", "load_run_case", "main", "read_summary", "run_case_path",
    # re-exported: the docs, the examples and the changelog named them ``media.charts.X``
    "GifStream", "RunEnd", "activity_intervals", "gantt_agents", "gantt_agents_figure",
    "gantt_tasks", "gantt_tasks_figure", "resource_profile", "resource_profile_figure",
    "run_end", "stall_picture", "trajectories", "write_gif",
]

CHART_FILES = ("gantt_agents.png", "gantt_tasks.png", "trajectories.png", "resource_profile.png")


def read_summary(run_dir: Path) -> dict | None:
    """``run_dir/summary.json`` as a dict; None when it is absent or unreadable (the charts
    then judge the run from its log and case alone)."""
    try:
        data = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return data if isinstance(data, dict) else None


def draw_run(run_dir: str | Path, case: Case) -> list[Path]:
    """Draw Figs. 9-11 and the resource profile of a saved run from ``run_dir/events.csv``
    into ``run_dir``.

    How the run ended (:func:`run_end`) comes from ``run_dir/summary.json`` when there is one,
    else from the log and the case's number of tasks; a case with a working calendar (its
    ``case.json`` keeps the one the run used) gives both Gantt charts and the resource
    profile a date axis. Returns the paths of ``gantt_agents.png``, ``gantt_tasks.png``,
    ``resource_profile.png`` (:func:`resource_profile`) and ``trajectories.png`` (not drawn
    for a run on the event floor: see the module doc). Raises
    FileNotFoundError when there is no ``events.csv`` and ValueError when the log names tasks
    that ``case`` does not define (the run was made with another case).
    """
    run_dir = Path(run_dir)
    log = run_dir / "events.csv"
    if not log.is_file():
        raise FileNotFoundError(f"{log}: no event log; fix: pass a run folder written with "
                                "env.log.write_csv(run_dir / 'events.csv')")
    events = read_csv(log)
    unknown = unknown_tasks(events, case)
    if unknown:
        shown = ", ".join(unknown[:5]) + (", ..." if len(unknown) > 5 else "")
        raise ValueError(f"{log}: {len(unknown)} task(s) not in case {case.case.name!r} "
                         f"({shown}); fix: pass the case the run was made with")
    summary = read_summary(run_dir)
    event_floor = (summary or {}).get("fidelity") == "event"
    name = case.case.name + (" (event floor)" if event_floor else "")
    end = run_end(events, len(case.tasks), summary)
    return [
        gantt_agents(events, run_dir / CHART_FILES[0], title=f"Crews' activities: {name}",
                     end=end, calendar=case.calendar),
        gantt_tasks(events, run_dir / CHART_FILES[1], case=case, title=f"Tasks: {name}",
                    end=end),
        resource_profile(events, case, run_dir / CHART_FILES[3],
                         title=f"Resources over time: {name}", end=end),
        # paths need positions along the walks, which the event floor does not have
        *([] if event_floor else [trajectories(events, case, run_dir / CHART_FILES[2])]),
    ]


def run_case_path(run_dir: Path) -> Path | None:
    """The resolved case ``cmdp-simulate`` saved with a run: ``case.json`` in the run folder,
    or in its parent (a ``seed-K/`` folder of a multi-episode run); None when there is none."""
    for folder in (run_dir, run_dir.parent):
        if (folder / "case.json").is_file():
            return folder / "case.json"
    return None


def load_run_case(path: Path | None) -> Case:
    """A case from a TOML case file, a resolved ``case.json``, or None (the built-in case).

    Raises ``cmdp_pymunk.cases.load.CaseError`` for a file that cannot be read or is not a valid
    case.
    """
    from cmdp_pymunk.cases.load import CaseError, case_from_dict, load_case

    if path is None or path.suffix.lower() != ".json":
        return load_case(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise CaseError(str(path), [f"cannot read the resolved case ({err}); fix: pass the "
                                    "run's case file with --case"]) from None
    return case_from_dict(data, path.name)


def main(argv: list[str] | None = None) -> int:
    """``python -m media.charts RUN_DIR [--case PATH]``: redraw a saved run's charts."""
    from cmdp_pymunk import add_version_flag

    parser = argparse.ArgumentParser(prog="python -m media.charts",
                                     description="Redraw Figs. 9-11 and the resource "
                                                 "profile of a saved run from its events.csv.")
    add_version_flag(parser)
    parser.add_argument("run_dir", type=Path, help="run folder holding events.csv")
    parser.add_argument("--case", type=Path, default=None,
                        help="the run's case: a case file (TOML) or a resolved case.json; "
                             "default: case.json in RUN_DIR or its parent, else the built-in "
                             "case")
    ns = parser.parse_args(argv)
    prog = parser.prog
    if not (ns.run_dir / "events.csv").is_file():
        print(f"{prog}: {ns.run_dir / 'events.csv'} does not exist; fix: pass a run folder "
              "that holds the run's events.csv (written by env.log.write_csv)", file=sys.stderr)
        return 2
    from cmdp_pymunk.cases.load import CaseError

    try:
        case = load_run_case(ns.case if ns.case is not None else run_case_path(ns.run_dir))
    except CaseError as err:
        print(f"{prog}: {err}", file=sys.stderr)
        return 2
    try:
        written = draw_run(ns.run_dir, case)
    except ValueError as err:
        print(f"{prog}: {err}", file=sys.stderr)
        return 2
    for p in written:
        print(f"{prog}: wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
