"""A run's cost (cmdp_pymunk.cost): worked out by hand on the tiny case; the [cost] section's
checks; cases without the new sections dump (and fingerprint) as before."""

from __future__ import annotations

import tomllib

import pytest
from conftest import tiny_file_data

from cmdp_pymunk.cases.load import BUILTIN_CASE, TINY_CASE, CaseError, case_from_dict, load_case
from cmdp_pymunk.cost import (
    case_cost,
    cost_model,
    crane_lifts,
    crews_by_type,
    run_cost,
    with_crew_rates_scaled,
)
from cmdp_pymunk.eventfloor.calibration import beside, fingerprint
from cmdp_pymunk.events import Event


def tiny_with(**sections) -> dict:
    """The tiny case file's data with ``sections`` put in."""
    return tiny_file_data(**sections)


COST = {"currency": "EUR", "crew_rate_per_h": {"HIC": 250.0}, "default_crew_rate_per_h": 200.0,
        "crane_per_h": 150.0, "crane_per_lift": 10.0, "overhead_per_h": 250.0,
        "due_s": 1800.0, "penalty_per_day": 100.0, "day_s": 28800.0}


def test_run_cost_by_hand_on_the_tiny_case():
    case = case_from_dict(tiny_with(cost=COST))
    assert crews_by_type(case) == {"HIC": 1, "RC": 1}
    # one hour: crews 250 (HIC, named) + 200 (RC, the default) + crane 150 + overhead 250
    # = 850; 3 lifts x 10 = 30; 1800 s past due = 1800 / 28800 = 0.0625 days x 100 = 6.25
    assert run_cost(3600.0, crews_by_type(case), 3, cost_model(case)) == pytest.approx(886.25)
    # crew rates doubled: 500 + 400 + 150 + 250 = 1300, + 30 + 6.25
    doubled = with_crew_rates_scaled(cost_model(case), 2.0)
    assert run_cost(3600.0, crews_by_type(case), 3, doubled) == pytest.approx(1336.25)
    assert case_cost(case, 3600.0, 3, crew_rate_factor=2.0) == pytest.approx(1336.25)
    # on time: no penalty; half an hour: 425 + 30
    assert case_cost(case, 1800.0, 3) == pytest.approx(455.0)
    assert case_cost(case, None, 3) is None  # a run that did not finish


def test_a_case_without_cost_is_costed_at_the_stated_defaults():
    case = load_case(TINY_CASE)
    assert case.cost is None
    # (200 + 200 + 150 + 250) per hour for two hours, no lift charge, no due date
    assert case_cost(case, 7200.0, 5) == pytest.approx(1600.0)


def test_crane_lifts_counts_the_cranes_completed_services():
    log = [Event(10.0, "crane_request", "RC-1", "ST", "material"),
           Event(130.0, "crane_done", "RC-1", "ST", "material"),
           Event(200.0, "crane_done", "HIC-1", "HI-P-1", "task"),
           Event(210.0, "task_finish", "HIC-1", "HI-P-1")]
    assert crane_lifts(log) == 2


@pytest.mark.parametrize("cost, words", [
    ({"crew_rate_per_h": {"RX": 1.0}}, ['crew_rate_per_h names unknown crew type "RX"', "fix:"]),
    ({"penalty_per_day": 5.0}, ["penalty_per_day", "fix: add due_s"]),
    ({"crane_per_h": -1.0}, ["cost: crane_per_h", "fix:"]),
])
def test_a_bad_cost_section_is_refused_with_the_fix(cost, words):
    with pytest.raises(CaseError) as err:
        case_from_dict(tiny_with(cost=cost), "tiny.toml")
    text = str(err.value)
    assert all(w in text for w in words), text


def test_cases_without_the_new_sections_dump_and_fingerprint_as_before():
    case = load_case(BUILTIN_CASE)
    dump = case.model_dump(mode="json")
    assert "cost" not in dump and "levers" not in dump and "calendar" not in dump
    committed = tomllib.loads(beside(BUILTIN_CASE).read_text())["event_floor"]["fingerprint"]
    assert fingerprint(case) == committed
    # cost and levers are the site's economics and options, not the floor the event floor's
    # numbers were fitted on: setting them keeps the fingerprint
    raw = tomllib.loads(BUILTIN_CASE.read_text())
    raw["cost"] = {"crane_per_h": 99.0}
    raw["levers"] = {"crews": {"RC": {"min": 1, "max": 4}}}
    assert fingerprint(case_from_dict(raw)) == committed
