"""The scripted navigator's planning: regression tests for the stalls it caused."""

import math

import numpy as np
import pytest

from agents.navigator import Navigator


def test_carrot_out_of_a_blocked_cell_takes_the_free_cell_lowest_on_the_field(tiny_env):
    """Seed 102 (built-in case): FC-1 was squeezed into a blocked cell against a component's
    corner; the nearest free cell lay on the lane a parked crew blocked (a detour field prices
    it at 1e4), an equally near one on the free lane beside it. Heading for the first kept it
    pushing into the parked crew for 3,000 s."""
    nav = Navigator().plans(tiny_env.engine)  # this episode's grid and fields
    field = np.full((nav.ny, nav.nx), 50.0)
    i, j = nav._cell(0.1, 0.1)
    field[j, i] = math.inf                 # the crew's own cell: blocked
    field[j, i - 1] = math.inf
    field[j - 1, i] = math.inf
    field[j, i + 1] = 1e4                  # first in scan order: behind the parked crew
    field[j + 1, i] = 12.0                 # as near, and on the free lane
    x, y = nav._carrot(field, 0.1, 0.1, lowest=True)  # on a detour
    assert (x, y) == (pytest.approx(nav.cx[0, i]), pytest.approx(nav.cy[j + 1, 0]))
    x, y = nav._carrot(field, 0.1, 0.1)  # on its own field: the nearest, as before
    assert (x, y) == (pytest.approx(nav.cx[0, i + 1]), pytest.approx(nav.cy[j, 0]))


def test_carrot_prefers_nearer_ring_over_lower_value(tiny_env):
    nav = Navigator().plans(tiny_env.engine)
    field = np.full((nav.ny, nav.nx), math.inf)
    i, j = nav._cell(0.1, 0.1)
    field[j, i + 1] = 40.0                 # ring 1
    field[j, i - 2] = 1.0                  # ring 2: lower, but farther
    x, y = nav._carrot(field, 0.1, 0.1, lowest=True)
    assert (x, y) == (pytest.approx(nav.cx[0, i + 1]), pytest.approx(nav.cy[j, 0]))


@pytest.mark.slow
def test_seed_102_finishes_with_priority_and_scripted_navigator(tmp_path):
    """The whole episode that stalled at t = 41,461 s before the fix."""
    from training import simulate

    out = tmp_path / "s102"
    assert simulate.main(["--seed", "102", "--out", str(out), "--no-charts",
                          "--no-progress"]) == 0
