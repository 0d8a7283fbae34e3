"""Reachability before simulation (``cmdp_pymunk.cases.reach``, issue 31 item 2): floors built
to have an unreachable work point, storage or start are refused when loaded, named with the fix;
every committed floor passes."""

from __future__ import annotations

import math

import pytest
from conftest import tiny_dict

from cmdp_pymunk import BUILTIN_CASE, DISRUPTED_CASE, TINY_CASE, load_case
from cmdp_pymunk.cases.generated import layout_files
from cmdp_pymunk.cases.load import CaseError, case_from_dict
from cmdp_pymunk.cases.reach import CLEARANCE_M, PlaneGrid, regions, unreachable


def wall(wid: str, x0: float, y0: float, x1: float, y1: float) -> dict:
    return {"id": wid, "kind": "wall", "x_m": (x0 + x1) / 2, "y_m": (y0 + y1) / 2,
            "width_m": x1 - x0, "height_m": y1 - y0}


def refused(data: dict) -> str:
    with pytest.raises(CaseError) as err:
        case_from_dict(data, "tiny.toml")
    return str(err.value)


def ring() -> list[dict]:
    """A ring of walls around C (x 0..1, y -0.5..0.5), outside its M work point (M's task
    area grows C by 1.0 and the approach band by 0.6 more: x -1.6..2.6, y -2.1..2.1), its
    corners left 0.05 m open (an MC crew of radius sqrt(1 / pi) = 0.564 m needs
    2 * (0.564 - 0.2) = 0.73 m on the navigator's grid)."""
    return [wall("W-top", -1.95, 2.4, 3.2, 2.6), wall("W-bottom", -1.95, -2.6, 3.2, -2.4),
            wall("W-left", -1.95, -2.35, -1.75, 2.35), wall("W-right", 3.0, -2.35, 3.2, 2.35)]


def test_a_work_point_in_a_closed_ring_is_refused():
    d = tiny_dict()
    d["components"] += ring()
    text = refused(d)
    assert "1 problem(s)" in text
    assert ("tasks: M-C (M on C): no MC crew can reach its work point from where the MC crews "
            "start: every way there is narrower than 0.73 m") in text
    assert "fix: widen a joint or lane next to C" in text


def test_a_storage_walled_off_from_its_crews_is_refused():
    # S spans x 4.5..7.5, y 3.5..5.5; walls below and left of it, the plane's edge above and
    # right; M-2 moved out of the corner it would be shut in
    d = tiny_dict()
    d["crews"][3]["start_y_m"] = -4.5
    d["components"] += [wall("W-below", 3.6, 3.0, 9.99, 3.3),
                        wall("W-left", 3.6, 3.35, 3.9, 5.99)]
    assert "storages: S (bars) cannot be reached by the MC crews, who fetch from it" in refused(d)


def test_a_crew_starting_where_it_does_not_fit_is_refused():
    # A's top edge is at y 1.0; X-1 at y 1.2 stands 0.2 m from it, less than its radius
    # 0.564 less the 0.2 m clearance
    d = tiny_dict()
    d["crews"][0].update(start_x_m=-3.0, start_y_m=1.2)
    assert "crews: X-1 starts where a XC crew (0.56 m radius) does not fit" in refused(d)


def test_the_grid_closes_a_lane_narrower_than_the_crew_and_opens_a_wider_one():
    # a wall across the plane with a gap centred on y = 0: the cells in it are centred at
    # y = +-0.25 (0.5 m cells), gap / 2 - 0.25 from the wall's ends; a crew of radius
    # sqrt(1 / pi) = 0.564 m needs 0.564 - 0.2 = 0.364 m there: a 1.5 m gap leaves 0.5 m (open),
    # a 1.0 m gap 0.25 m (closed, though wider than the crew's 2 * 0.364 = 0.73 m on paper)
    radius = math.sqrt(1.0 / math.pi)
    grid = PlaneGrid.of((10.0, 6.0))
    for gap, connected in ((1.5, True), (1.0, False)):
        walls = [(-0.5, -6.0, 0.5, -gap / 2), (-0.5, gap / 2, 0.5, 6.0)]
        labels = regions(grid, ~grid.blocked(walls, radius + CLEARANCE_M))
        left, right = labels[grid.cell(-5.0, 0.0)[::-1]], labels[grid.cell(5.0, 0.0)[::-1]]
        assert bool(left == right) == connected, gap


@pytest.mark.parametrize("path", [BUILTIN_CASE, TINY_CASE, DISRUPTED_CASE,
                                  *layout_files("train"), *layout_files("test")],
                         ids=lambda p: p.stem)
def test_every_committed_floor_is_reachable(path):
    assert unreachable(load_case(path)) == []


def ring_with_a_deck(laid_by_k: bool) -> dict:
    """The ring with its left wall a deck (walked on once laid), laid by K-WL (a crane task
    of the KC crew, reached from outside: the wall's task area, grown by 1.5 m and the band's
    0.6, reaches above A) when ``laid_by_k``, else never (no task on it)."""
    d = tiny_dict()
    d["components"] += ring()
    d["components"][-2]["deck"] = True
    if laid_by_k:
        d["tasks"].append({"id": "K-WL", "type": "K", "component": "W-left"})
    return d


def test_a_deck_in_the_ring_opens_it_once_laid():
    """The check's fixed point takes K-WL, lays the deck, then reaches M-C over it; on the
    floor M-C is offered to no MC crew before K-WL has ended (it waits as for a predecessor)
    and the crews walk in over the laid deck, on both floors."""
    from agents.navigator import Navigator
    from cmdp_pymunk.cases.reach import laying_tasks, taken_in_order
    from cmdp_pymunk.eventfloor.floor import make_floor
    from cmdp_pymunk.rollout import run_episode

    case = case_from_dict(ring_with_a_deck(True), "tiny.toml")
    assert laying_tasks(case) == {"K-WL": "W-left"}
    order, laid = taken_in_order(case)
    ids = [case.tasks[k].id for k in order]
    assert ids.index("M-C") > ids.index("K-WL") and laid == {5}  # W-left: components[5]
    for fidelity in ("pymunk", "event"):
        floor = make_floor(case, fidelity, evaluator="priority")
        assert run_episode(floor, Navigator(), 0, stall_s=None, progress=False).makespan_s
        tasks = {t.id: t for t in floor.site.tasks}
        assert tasks["M-C"].started_s >= tasks["K-WL"].ended_s, fidelity
        assert floor.site.laid == {5}


def test_a_deck_never_laid_leaves_the_ring_closed():
    text = refused(ring_with_a_deck(False))
    assert ("tasks: M-C (M on C): no MC crew can reach its work point from where the MC crews "
            "start, over open floor and the decks laid before it (0 of 1 decks can be laid)"
            ) in text


def test_a_floor_cloned_after_a_deck_is_laid_goes_on_as_the_original():
    """A clone rebuilds its plane from the site: the laid deck stays out of the space (the
    walled-in M-C is still reached), and the clone and the original end identically."""
    from agents.navigator import Navigator
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.rollout import play

    case = case_from_dict(ring_with_a_deck(True), "tiny.toml")
    engine = Engine(case, evaluator="priority")
    engine.reset(0)
    navigator = Navigator()
    while not engine.site.laid:
        engine.advance(navigator.actions(engine), until=engine.decision_due)
    branch = engine.clone()
    assert 5 not in branch.world.component_shapes and 5 not in engine.world.component_shapes
    play(engine, navigator)
    play(branch, navigator)
    assert engine.site.done and branch.site.done
    assert [t.ended_s for t in engine.site.tasks] == [t.ended_s for t in branch.site.tasks]
