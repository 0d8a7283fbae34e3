"""Would event-floor walks that plan around areas, as the pymunk navigator does, serve variants
better? An experiment, not a mode of the event floor (docs/event-floor.md, "Variants on the
base's calibration").

    PYTHONPATH=. python benchmarks/probe_costed_walks.py [--area-cost 4] [--storage-cost 1.5]
        [--seeds 100-139] [--variant ST-rebars.x_m=-6 --variant crews.FC+1]

The pymunk navigator weighs a cell of an active task area 4 and of a storage 1.5 times open
floor (``agents/navigator.py``: ``AREA_COST``, ``STORAGE_COST``); the event floor's paths are
shortest in metres. Here the walk planner's graphs are reweighted by those costs from the
site's areas and storages, and every kept field and path is dropped whenever the set of areas
on the plane changes (so about 2 s a floor instead of 0.08: too slow to ship). Prints the base's
mean makespan and each variant's paired difference to it (mean ± 95 % interval), Eq. 9, the
case's calibration. ``--area-cost 1 --storage-cost 1`` plans by metres again and gives the
event floor's own numbers exactly (the harness's check).
"""

from __future__ import annotations

import argparse

import numpy as np

import cmdp_pymunk
from training.cli import seed_list


def costed_planner(area_cost: float, storage_cost: float) -> None:
    """Patch the walk planner (this process only) to plan around areas (see the module doc)."""
    from scipy.sparse import csr_matrix

    from cmdp_pymunk.eventfloor import walks

    current = [None]  # the site the walk being planned is on

    def reweight(grid, plane, site) -> None:
        if not hasattr(grid, "metres"):
            grid.metres = grid.edges[2]
        cost = np.ones(plane.nx * plane.ny)
        for t in site.active_areas:
            cost[plane.rect_mask(site.tasks[t].area).ravel()] = area_cost
        for storage in site.storages:
            cells = plane.rect_mask(storage.rect).ravel()
            cost[cells] = np.maximum(cost[cells], storage_cost)
        src, dst = grid.edges[0], grid.edges[1]
        weight = grid.metres * 0.5 * (cost[src] + cost[dst])
        n = plane.nx * plane.ny
        grid.graph = csr_matrix((weight, (src, dst)), shape=(n, n))
        grid.edges = (src, dst, weight)

    made = walks._Radius.__init__

    def radius_init(self, plane, components, radius):
        made(self, plane, components, radius)
        reweight(self, plane, current[0])

    plan = walks.WalkPlanner.walk

    def walk(self, site, crew, start, target, now_s, walk_factor, dock_s=0.0, areas=None):
        current[0] = site
        layer = self._layer(site.laid)
        key = tuple(site.active_areas)
        if getattr(layer, "area_key", None) != key:
            layer.fields.clear()
            layer.paths.clear()
            layer.area_key = key
            for grid in layer.radii.values():
                reweight(grid, self.plane, site)
        return plan(self, site, crew, start, target, now_s, walk_factor, dock_s, areas)

    walks._Radius.__init__ = radius_init
    walks.WalkPlanner.walk = walk


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--area-cost", type=float, default=4.0)
    p.add_argument("--storage-cost", type=float, default=1.5)
    p.add_argument("--seeds", type=seed_list, default=seed_list("100-139"))
    p.add_argument("--variant", action="append", default=None)
    a = p.parse_args(argv)
    from cmdp_pymunk.cases.levers import make_variant
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for
    from cmdp_pymunk.eventfloor import floor as event_floor

    costed_planner(a.area_cost, a.storage_cost)
    case = cmdp_pymunk.load_case(None)
    calibration = calibration_for(case, None)
    makespans = {}
    for name in ["base", *(a.variant or ["ST-rebars.x_m=-6", "crews.FC+1"])]:
        floor_case = case if name == "base" else make_variant(case, name).case
        event_floor._PLANNERS.clear()  # a planner of its own, patched from the start
        event_floor._BY_CONTENT.clear()
        floor = EventFloor(floor_case, evaluator="priority", stall_s=3600.0,
                           calibration=calibration)
        runs = []
        for seed in a.seeds:
            floor.reset(seed)
            floor.run()
            runs.append(floor.makespan_s)
        makespans[name] = np.asarray(runs, dtype=float)
    base = makespans.pop("base")
    print(f"area cost {a.area_cost}, storage cost {a.storage_cost}, {len(a.seeds)} seeds: base "
          f"mean {base.mean():,.0f} s")
    for name, runs in makespans.items():
        diff = runs - base
        half = 1.96 * diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else float("nan")
        print(f"  {name}: {diff.mean():+,.0f} ± {half:,.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
