"""The research seam (issue 43): labelling is a wrapper in research around the lookahead's
public face (``candidates_for``, ``decide``); the lookahead knows nothing of labels."""

from __future__ import annotations

import math

import pytest
from conftest import play_floor

from agents.lookahead import LookaheadEvaluator, LookaheadSettings
from agents.specs import evaluator_from_spec
from training.research.labelling import CandidatesOnly, Labeller


def _teacher():
    return LookaheadEvaluator(settings=LookaheadSettings(2, 1, expected_paces=True))


def test_a_test_labeller_sees_every_decision_of_a_lookahead_that_drives(tiny_case):
    seen = []
    labeller = Labeller(_teacher(), on_decision=lambda e, i, v, d: seen.append(
        (e.site.time_s, i, sorted(v), d)))
    env = play_floor(labeller, tiny_case)
    alone_teacher = _teacher()
    alone = play_floor(alone_teacher, tiny_case)
    # the wrapper changes nothing of the floor the lookahead drives
    assert env.engine.site.done and env.log.events == alone.log.events
    assert seen and [d for *_, d in seen] == labeller.decisions
    assert [(d.time_s, d.crew, d.candidates, d.makespans_s, d.choice)
            for d in labeller.decisions] == [(d.time_s, d.crew, d.candidates, d.makespans_s,
                                              d.choice) for d in alone_teacher.decisions]
    for time_s, i, targets, d in seen:  # the values handed on are the base's for that crew
        assert time_s == d.time_s and i == d.crew and set(d.candidates) <= set(targets)


def test_an_acting_policy_drives_the_floor_while_the_lookahead_labels(tiny_case):
    # DAgger's labelling: the floor is the acting policy's own, and every decision with a
    # choice is still branched and recorded
    labeller = Labeller(_teacher(), acting=evaluator_from_spec("nearest"))
    env = play_floor(labeller, tiny_case)
    alone = play_floor(evaluator_from_spec("nearest"), tiny_case)
    assert env.engine.site.done and env.log.events == alone.log.events
    assert labeller.decisions
    assert all(len(d.makespans_s) == 2 and all(map(math.isfinite, d.makespans_s))
               for d in labeller.decisions)
    with pytest.raises(ValueError, match="plain evaluator"):
        Labeller(_teacher(), acting=_teacher())


def test_candidates_only_branches_nothing_and_keeps_the_base_choice(tiny_case):
    teacher = _teacher()
    labeller = Labeller(CandidatesOnly(teacher), acting=evaluator_from_spec("priority"))
    env = play_floor(labeller, tiny_case)
    alone = play_floor(evaluator_from_spec("priority"), tiny_case)
    assert env.log.events == alone.log.events
    assert labeller.decisions and teacher.decisions == []  # nothing was branched
    assert all(d.choice == d.base_choice == d.candidates[0]
               and all(math.isnan(m) for m in d.makespans_s) for d in labeller.decisions)
