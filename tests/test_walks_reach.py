"""The event floor's walks under the one reach rule (issue 41 item 3): a walk to a task ends only
where the case check counts the task reached (``cases.reach``: a free cell holding, or beside, a
point of the task area where the crew fits), stops at such a point without stepping through a
component, and a target the check calls unreachable is never arrived at: the floors the check
refuses stall on the event floor as on the pymunk floor, the floors it passes finish."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cmdp_pymunk
from agents.navigator import Navigator
from cmdp_pymunk.cases import load
from cmdp_pymunk.cases.reach import Reach, fit_distance, in_area, too_close
from cmdp_pymunk.eventfloor.floor import make_floor
from cmdp_pymunk.eventfloor.walks import WalkPlanner
from cmdp_pymunk.precedence import Pool
from cmdp_pymunk.rollout import run_episode
from cmdp_pymunk.state import Site
from tests.test_reach_rule import JCC_RADIUS, fenced_slabs, isolated_joints


def _forced(data: dict, monkeypatch):
    """The case of ``data`` with the reach check switched off (a refused floor, run anyway)."""
    with monkeypatch.context() as m:
        m.setattr(load, "unreachable", lambda case: [])
        return load.case_from_dict(data, "forced.toml")


def _inside_a_component(site: Site, xs: list, ys: list) -> bool:
    """Whether the walk's polyline (tested every 2 cm) enters a component's rectangle."""
    for x0, y0, x1, y1 in zip(xs[:-1], ys[:-1], xs[1:], ys[1:], strict=True):
        t = np.linspace(0.0, 1.0, max(2, int(math.hypot(x1 - x0, y1 - y0) / 0.02) + 2))
        px, py = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
        for c in site.components:
            r = c.rect
            if ((px > r[0]) & (px < r[2]) & (py > r[1]) & (py < r[3])).any():
                return True
    return False


def test_walks_end_where_the_check_counts_the_task_reached():
    """On the built-in floor, from 30 random places to random tasks: the path's last cell is
    one of the check's cells for the task (free, in ``Reach.work_point``), the walk stops in
    the task area (``in_area``, the decision table's test) where the crew fits (its centre
    ``fit_distance`` off every component), and no step of it enters a component."""
    case = cmdp_pymunk.load_case()
    site = Site(case, 2)
    planner, reach = WalkPlanner(site), Reach.of(case)
    rng = np.random.default_rng(7)
    hw, hh = case.plane.half_extents
    for trial in range(30):
        task = site.tasks[int(rng.integers(len(site.tasks)))]
        crew = next(c for c in site.crews if c.type == task.crew_type)
        crew.scope = {task.component: task.index}
        start = (float(rng.uniform(-hw, hw)), float(rng.uniform(-hh, hh)))
        walk = planner.walk(site, crew, start, task.component, 0.0, 1.0)
        assert math.isfinite(walk.arrival_s), trial
        radius = crew.spec.radius_m
        i, j = reach.grid.cell(walk.xs[-2], walk.ys[-2])  # the path's last cell's centre
        assert (reach.grid.cx[j, i], reach.grid.cy[j, i]) == (walk.xs[-2], walk.ys[-2])
        assert reach.work_point(radius, task.index)[j, i], trial
        assert reach.labels(radius)[j, i] >= 0, trial
        x, y = walk.xs[-1], walk.ys[-1]
        assert in_area(x, y, task.area), trial
        assert not too_close(np.array([x]), np.array([y]), reach.rects, fit_distance(radius),
                             hw, hh)[0], trial
        assert not _inside_a_component(site, walk.xs[1:], walk.ys[1:]), trial


def test_a_walk_to_an_area_reached_only_at_its_corners_stops_at_a_corner(monkeypatch):
    """The fenced slabs with open corners (``test_reach_rule.fenced_slabs``): S-1 spans x
    -4..0, y -1.5..1.5, so its JC area (1.2 m round it) spans x -5.2..1.2, y -2.7..2.7; the
    top beam runs y 1.5..1.9 from x -4.4, the left beam x -4.4..-4.0. A JCC's centre keeps
    1.128 - 0.1 = 1.03 m off them: along the area's top edge (y 2.7, 0.8 m above the beam) only
    where (x + 4.4)^2 >= 1.03^2 - 0.8^2, x <= -5.05; so the walk stops within 0.15 m of an
    outer corner (-5.2, +-2.7), never beside the beam where the band round the area ended a
    walk before."""
    case = _forced(fenced_slabs(corners_open=True), monkeypatch)
    site = Site(case, 2)
    planner = WalkPlanner(site)
    task = next(t for t in site.tasks if t.type == "JC" and case.components[t.component].id
                == "S-1")
    assert task.area == pytest.approx((-5.2, -2.7, 1.2, 2.7))
    crew = next(c for c in site.crews if c.type == "JCC")
    assert crew.spec.radius_m == pytest.approx(JCC_RADIUS)
    crew.scope = {task.component: task.index}
    for start in ((0.0, 6.0), (-3.0, -6.0), (-9.0, 0.5), (6.0, 3.0)):
        walk = planner.walk(site, crew, start, task.component, 0.0, 1.0)
        x, y = walk.xs[-1], walk.ys[-1]
        assert -5.2 <= x <= -5.05 and 2.55 <= abs(y) <= 2.7, (start, x, y)
        assert math.hypot(x + 4.4, abs(y) - 1.9) >= 1.03, start
        assert not _inside_a_component(site, walk.xs, walk.ys), start


def test_a_target_the_check_refuses_is_never_arrived_at(monkeypatch):
    """The fenced slabs closed to the corners: nowhere in S-1's JC area does a JCC fit (the
    check's refusal); its walk there has no path: it stays where it starts and never
    arrives."""
    case = _forced(fenced_slabs(corners_open=False), monkeypatch)
    site = Site(case, 2)
    task = next(t for t in site.tasks if t.type == "JC")
    crew = next(c for c in site.crews if c.type == "JCC")
    crew.scope = {task.component: task.index}
    assert not Reach.of(case).fits_in_area(crew.spec.radius_m, task.index).any()
    walk = WalkPlanner(site).walk(site, crew, (0.0, 6.0), task.component, 100.0, 1.0)
    assert walk.arrival_s == math.inf
    assert walk.at(1e6) == (0.0, 6.0) and walk.distance_at(1e6) == 0.0


@pytest.mark.parametrize(("name", "data", "refused", "ended"), [
    ("isolated joints, 2 m lanes", lambda: isolated_joints(2.0), False, 26),
    ("isolated joints, 1.8 m lanes", lambda: isolated_joints(1.8), True, None),
    ("fenced slabs, corners open", lambda: fenced_slabs(corners_open=True), False, 14),
    ("fenced slabs", lambda: fenced_slabs(corners_open=False), True, 0),
])
def test_the_event_floor_finishes_what_the_check_passes_and_no_more(name, data, refused,
                                                                    ended, monkeypatch):
    """Each floor of ``test_reach_rule`` on the event floor (Eq. 9, seed 0, the check
    bypassed): a floor that loads ends every task; a refused one stalls (the fenced slabs
    with none ended: every chain starts with the JC that no JCC reaches; the 1.8 m lanes with
    the F of the middle joint never ended). Before the walks ended where the check does,
    every one of them finished."""
    made = data()
    if refused:
        with pytest.raises(load.CaseError):
            load.case_from_dict(made, "refused.toml")
    case = _forced(made, monkeypatch)
    floor = make_floor(case, "event", evaluator="priority")
    episode = run_episode(floor, Navigator(), 0, stall_s=3600.0, progress=False)
    if not refused:
        assert episode.stalled is None and floor.site.done, name
        assert floor.site.tasks_ended == ended
        return
    assert episode.stalled is not None and episode.makespan_s is None, name
    if ended is not None:
        assert floor.site.tasks_ended == ended
    else:
        assert next(t for t in floor.site.tasks if t.id == "F-V-2").pool != Pool.END
