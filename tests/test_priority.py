"""Eq. 9 with hand-computed values, and the evaluator on the tiny case."""

import pytest

from cmdp_pymunk.evaluate import PriorityEvaluator, as_target_values, priority_value


def test_eq9_priority_value():
    # Suc 3 of max 6, Dis 10 of max 20, Spa 1 of max 4:
    # 1 * 0.5 + 0.5 * (1 - 0.5) - 1 * 0.25 = 0.5 + 0.25 - 0.25 = 0.5
    assert priority_value(3, 10.0, 1, 6, 20.0, 4) == pytest.approx(0.5)
    # the farthest target with most conflicts and no successors: 0 + 0 - 1 = -1
    assert priority_value(0, 20.0, 4, 6, 20.0, 4) == pytest.approx(-1.0)
    # maxima of 0 contribute nothing: a lone target with no successors or conflicts
    # at distance 5 of max 5 -> 0.5 * (1 - 1) = 0
    assert priority_value(0, 5.0, 0, 0, 5.0, 0) == 0.0
    # other betas
    assert priority_value(2, 0.0, 0, 2, 10.0, 0, betas=(2.0, 1.0, -1.0)) == pytest.approx(3.0)


def test_priority_prefers_the_task_that_unblocks_more(tiny_env):
    env = tiny_env
    crew = env.engine.site.crews[0]  # scope A (X-A -> K-A -> M-C: 2 successors), B (none)
    evaluator = PriorityEvaluator()
    priorities = evaluator.priorities(crew, env.engine.site, (1.0, 0.0))
    # A: Suc 2/2 -> 1; distance from (1,0): A at (-3,0) 4 m, B at (5,0) 4 m -> both 0.5*(0)=0;
    # conflicts with queued tasks: none queued around either -> 0. V'(A) = 1, V'(B) = 0.
    assert priorities == pytest.approx({0: 1.0, 1: 0.0})
    # as V_Tar: onto [0.5, 1], best 1
    assert evaluator.target_values(crew, env.engine.site, (1.0, 0.0)) == \
        pytest.approx({0: 1.0, 1: 0.5})


def test_priorities_become_positive_target_values():
    # V' of -1, 0 and 0.5 -> 0.5, 0.5 + 0.5 * 1/1.5, 1
    assert as_target_values({3: -1.0, 4: 0.0, 5: 0.5}) == pytest.approx(
        {3: 0.5, 4: 0.5 + 0.5 / 1.5, 5: 1.0})
    assert as_target_values({7: 0.0}) == {7: 1.0}  # a lone target is worth the most
    assert as_target_values({}) == {}


def test_agents_priority_still_names_the_core_heuristic():
    from agents import priority
    from cmdp_pymunk import evaluate

    for name in priority.__all__:
        assert getattr(priority, name) is getattr(evaluate, name), name
