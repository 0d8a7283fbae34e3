"""Labelling a floor with the lookahead's decisions: a wrapper around the lookahead's public
face (``candidates_for``, ``decide``), so that the lookahead itself knows nothing of labels.

``Labeller(teacher, acting=None, on_decision=None)`` is an evaluator:

- without ``acting`` the teacher (a ``LookaheadEvaluator``) drives the floor as it would alone,
  and each decision it takes is passed to ``on_decision(engine, i, values, decision)``;
- with ``acting`` (DAgger's labelling, ``distill label --acting``) the floor follows the
  acting policy (the student's own states), while the teacher still values the base's
  candidates at every decision and each ``Decision`` is passed on: the labels say what one
  step of lookahead would pick there.

``CandidatesOnly(teacher)`` stands in for a teacher where only the candidates are wanted (a
replay of old labels under their acting policy, ``relabel``): its ``decide`` branches nothing
and records the base's order.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from agents.lookahead import Decision, LookaheadEvaluator
from cmdp_pymunk.evaluate import Evaluator


class CandidatesOnly:
    """A teacher that only names the candidates (``decide`` branches nothing: every makespan
    is NaN, the base's first is the choice)."""

    between_seconds = True

    def __init__(self, teacher: LookaheadEvaluator):
        self.teacher = teacher
        self.base = teacher.base

    def prepare(self, case) -> None:
        self.teacher.prepare(case)

    def decide(self, engine, i: int, values: dict[int, float]) -> Decision | None:
        tried = self.teacher.candidates_for(engine, i, values)
        if tried is None:
            return None
        order, chosen = tried
        return Decision(engine.site.time_s, i, chosen, [np.nan] * len(chosen), order[0],
                        order[0], 0.0, None)


class Labeller(Evaluator):
    """An evaluator that labels a floor with a teacher's decisions (see the module doc)."""

    between_seconds = True  # the teacher branches the floor

    def __init__(self, teacher: LookaheadEvaluator | CandidatesOnly, acting=None,
                 on_decision: Callable | None = None):
        if acting is not None and acting.between_seconds:
            raise ValueError("the labeller's acting policy must be a plain evaluator (a rule or "
                             "a model), not one that branches the floor")
        self.teacher = teacher
        self.acting = acting
        self.on_decision = on_decision
        self.decisions: list[Decision] = []
        self._episode = None

    def prepare(self, case) -> None:
        self.teacher.prepare(case)
        if self.acting is not None:
            self.acting.prepare(case)

    def values_for(self, engine, i: int) -> dict[int, float]:
        if self._episode is not engine.site:  # a new episode
            self._episode, self.decisions = engine.site, []
        if self.acting is None:  # the teacher drives: its own values, its decisions passed on
            made = self.teacher.decisions
            last = made[-1] if made else None
            values = self.teacher.values_for(engine, i)
            made = self.teacher.decisions  # a new episode's list, maybe
            if made and made[-1] is not last:
                self._record(engine, i, self.teacher.base.values_for(engine, i),
                             self.teacher.decisions[-1])
            return values
        base = self.teacher.base.values_for(engine, i)
        decision = self.teacher.decide(engine, i, base)
        if decision is not None:
            self._record(engine, i, base, decision)
        return self.acting.values_for(engine, i)

    def _record(self, engine, i: int, values: dict[int, float], decision: Decision) -> None:
        self.decisions.append(decision)
        if self.on_decision is not None:
            self.on_decision(engine, i, values, decision)


__all__ = ["Labeller", "CandidatesOnly"]
