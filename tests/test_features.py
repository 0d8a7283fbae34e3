"""The candidate features of ``agents.features``: the case's facts (the binding crew type
under the pace law and loading) and the binding features, on recorded states of the event
floor (issue 32, item 2)."""

from __future__ import annotations

import numpy as np
import pytest

import cmdp_pymunk
from agents.features import (
    ALL_FEATURES,
    BINDING_FEATURES,
    FEATURE_NAMES,
    STATE_FEATURES,
    FloorFacts,
    candidate_features,
    load_shares,
)
from agents.student import StudentEvaluator
from cmdp_pymunk.bounds import expected_task_duration_s, expected_work_by_crew_type, loading_s
from cmdp_pymunk.evaluate import PriorityEvaluator, as_target_values
from cmdp_pymunk.state import ScopeKind


@pytest.fixture(scope="module")
def built_in():
    from cmdp_pymunk.cases.load import BUILTIN_CASE
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    case = cmdp_pymunk.load_case(None)
    floor = EventFloor(case, evaluator=PriorityEvaluator(), stall_s=3600.0,
                       calibration=calibration_for(case, BUILTIN_CASE))
    floor.reset(0)
    return floor


def test_the_binding_crew_type_is_reinforcing_where_the_mean_pace_says_formwork(built_in):
    site = built_in.site
    facts = FloorFacts.of(site)
    per_crew = expected_work_by_crew_type(site.case)
    assert facts.bottleneck == max(per_crew, key=per_crew.get) == "RC"
    assert facts.mean_pace_bottleneck == "FC"  # the first definition, kept (module doc)
    # an HI task unlocks its R successors' expected work with loading, by hand
    case = site.case
    hi = next(t for t in site.tasks if t.type == "HI" and any(
        site.tasks[s].crew_type == "RC" for s in t.successors))
    by_hand = sum(expected_task_duration_s(case, case.tasks[s]) + loading_s(case, case.tasks[s])
                  for s in hi.successors if site.tasks[s].crew_type == "RC")
    assert by_hand > 0 and facts.binding_unlock_s[hi.index] == pytest.approx(by_hand)
    # an R task unlocks no reinforcing work; under the mean pace it unlocked its one F task
    r = next(t for t in site.tasks if t.crew_type == "RC")
    assert facts.binding_unlock_s[r.index] == 0 < facts.unlock_s[r.index]


def test_binding_features_tell_candidates_apart_on_recorded_states(built_in):
    """Along Eq. 9's event floor on seeds 0-1, at each decision of a task scope with two or
    more candidates: the first eleven columns are ``candidate_features``'s default, and the
    binding features differ between candidates at some decisions (the old
    ``unlocks_bottleneck`` at none: every R task has one F successor)."""
    recorded = []
    facts = FloorFacts.of(built_in.site)

    class Recorder(PriorityEvaluator):
        def values_for(self, engine, i):
            site, crew = engine.site, engine.site.crews[i]
            priorities = self.priorities(crew, site, engine.positions[i])
            values = as_target_values(priorities)
            top = sorted(values, key=lambda t: -values[t])[:5]
            if crew.scope_kind == ScopeKind.TASKS and len(top) >= 2:
                every = candidate_features(facts, crew, site, engine.positions[i], top,
                                           priorities, engine.positions, ALL_FEATURES)
                first = candidate_features(facts, crew, site, engine.positions[i], top,
                                           priorities, engine.positions)
                assert np.array_equal(every[:, :len(FEATURE_NAMES)], first)
                ratios = every[:, :len(FEATURE_NAMES) + len(BINDING_FEATURES)]
                assert ((ratios >= 0) & (ratios <= 1)).all()
                assert (every >= 0).all()  # hours, hectometres: not scaled to 1
                recorded.append(every)
            return values

    built_in.evaluator = Recorder()
    try:
        for seed in (0, 1):
            built_in.reset(seed)
            built_in.run()
    finally:
        built_in.evaluator = PriorityEvaluator()
    assert len(recorded) > 50

    def separates(name):
        j = ALL_FEATURES.index(name)
        return sum(np.ptp(phi[:, j]) > 1e-9 for phi in recorded)

    assert separates("unlocks_bottleneck") == 0
    assert all(separates(n) > 0 for n in ("unlocks_binding", "releases_binding_now",
                                          "blocks_binding"))
    # the built-in floor's tasks of one type all have the same work: duration and tail never
    # tell a crew's candidates apart there (they may on other cases)
    same_work = ("duration_h", "tail_h", "tail_late_h")
    assert all(separates(n) == 0 for n in same_work)
    assert all(separates(n) > 0 for n in STATE_FEATURES if n not in same_work)


def test_a_student_with_binding_features_round_trips_and_old_files_still_load(tmp_path):
    names = ("successors", "nearness", *BINDING_FEATURES)
    student = StudentEvaluator({"RC": [0.1] * len(names)}, 4, names)
    student.save(tmp_path / "s.json", {})
    back = StudentEvaluator.load(tmp_path / "s.json")
    assert back.features == names and back.candidates == 4
    assert back.weights["RC"].tolist() == [0.1] * len(names)
    old = StudentEvaluator.load("models/searched_rule.json")  # the committed first features
    assert old.features == FEATURE_NAMES
    with pytest.raises(ValueError, match="each once"):
        StudentEvaluator({}, 3, ("successors", "crane_queue"))


def test_state_features_by_hand_at_the_floors_start(built_in):
    """At second 0 of seed 0 (nothing ended, nobody gone): each crew type's load share is its
    expected work per crew over the largest (``expected_work_by_crew_type``); a candidate's
    duration and the queued work of other types its area blocks, in hours, by hand; the tail
    weighted by progress is 0."""
    built_in.reset(0)
    site = built_in.site
    facts = FloorFacts.of(site)
    per_crew = expected_work_by_crew_type(site.case)
    top = max(per_crew.values())
    shares = load_shares(facts, site)
    assert shares == pytest.approx({ct: w / top for ct, w in per_crew.items()})
    crew = next(c for c in site.crews if c.type == "JCC")
    site.crews[crew.index].scope = {site.tasks[t].component: t
                                    for t in site.tasks_of_crew_type["JCC"][:3]}
    targets = list(crew.scope)
    phi = candidate_features(facts, crew, site, (0.0, 0.0), targets,
                             {t: 0.5 for t in targets}, None, STATE_FEATURES)
    for k, target in enumerate(targets):
        task = site.tasks[crew.scope[target]]
        assert phi[k, STATE_FEATURES.index("duration_h")] == pytest.approx(
            facts.expected_s[task.index] / 3600)
        other = [o for o in task.conflicts if site.tasks[o].crew_type != "JCC"
                 and site.tasks[o].pool == 1]  # queued
        assert phi[k, STATE_FEATURES.index("blocks_h")] == pytest.approx(
            sum(facts.expected_s[o] for o in other) / 3600)
        x, y = site.target_points[target]
        assert phi[k, STATE_FEATURES.index("distance_hm")] == pytest.approx(
            (x * x + y * y) ** 0.5 / 100)
    assert (phi[:, STATE_FEATURES.index("tail_late_h")] == 0).all()
