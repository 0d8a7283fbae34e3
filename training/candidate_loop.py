"""Stage 2 with the masked choice over a crew's best targets (``action = "candidate"``).

``CandidateLoop`` wraps a ``cmdp_pymunk.adapters.decision_loop.DecisionLoop`` with the action of
``agents.candidates`` (the index of one of the crew's ``cap`` best targets by Eq. 9) in place
of Eq. 4's desired position. It has the floor's interface (``reset``, ``decide``, ``observe``,
``low``/``high``, ``end_info``), so ``vec_env.FloorsVecEnv`` steps it as it steps a floor, plus
``action_masks()`` for sb3-contrib's MaskablePPO. A decision the policy has nothing to choose in
(a scope of storages or the crane, or one task target) is valued by Eq. 9 inside the step; its
reward goes to the policy's decision before it, as the floor's lone targets do.

Typed (``types``, ``Stage2Config.typed``): the rows carry the deciding crew's type
(``agents.candidates.CandidateView``). With ``hold_choice``, a choice other than Eq. 9's is
held as the deployed model holds it (``agents.hold``): while the hold lasts, the crew's
re-evaluations are valued without asking the policy, like decisions without a choice, so
training meets the decisions that deployment does.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from agents.candidates import CandidateView, has_choice, observation_bounds
from agents.hold import HeldChoices
from cmdp_pymunk.adapters.decision_loop import DecisionLoop, Outcome


def terminal_term(per_second: float, heuristic_s: float, time_s: float, finished: bool,
                  limit_s: float) -> float:
    """The reward added at a floor's end against the heuristic on the same seed (issue 17,
    item 5): with R_e's makespan term ``per_second`` (< 0) summed over the floor, the return's
    makespan part becomes ``per_second * (M - H)``, M the makespan (an unfinished floor: twice
    the time limit, ``training.search.genetic.unfinished_makespan_s``) and H the heuristic's."""
    makespan = time_s if finished else 2.0 * limit_s
    return -per_second * heuristic_s + per_second * (makespan - time_s)


class CandidateLoop:
    """A floor whose decisions are a choice among the deciding crew's best targets.

    ``against_heuristic``: a factory of a second floor like this one, to play Eq. 9 on each
    seed once (cached) for ``terminal_term``; ``seed_pool`` (> 0): episode seeds are taken
    modulo it (so the heuristic's makespans are reused); ``types``: the crew-type vocabulary
    of typed rows (() for untyped); ``hold_choice``: hold choices (the module doc)."""

    def __init__(self, floor: DecisionLoop, cap: int, against_heuristic=None, seed_pool: int = 0,
                 types: tuple[str, ...] = (), hold_choice: bool = False):
        self.floor, self.view = floor, CandidateView(cap, types)
        self.against_heuristic, self.seed_pool = against_heuristic, seed_pool
        self.held = HeldChoices() if hold_choice else None
        self._heuristic_s: dict[int, float] = {}
        self._reference: DecisionLoop | None = None  # where Eq. 9 plays each seed, made when needed
        self._seed: int | None = None
        self.low, self.high = observation_bounds(cap, len(self.view.types))
        self.actor_size = len(self.low)
        self.action_space = spaces.Discrete(cap)
        self._decision = None  # the deciding crew's CandidateDecision

    @property
    def engine(self):
        return self.floor.engine

    def reset(self, seed: int) -> float:
        if self.seed_pool:
            seed %= self.seed_pool
        self._seed = seed
        reward = self.floor.reset(seed)
        out = self._to_choice(Outcome(reward, False, False))
        if out.terminated or out.truncated:
            raise RuntimeError("the episode ended before any crew had a choice to make")
        return out.reward

    def decide(self, action) -> Outcome:
        """Row ``action`` chosen (an index into the last observation's rows)."""
        k = int(np.asarray(action).reshape(-1)[0])
        n = len(self._decision.targets)
        if not 0 <= k < n:
            raise ValueError(f"action {k}: only rows 0-{n - 1} are real (mask the others: "
                             "action_masks())")
        if self.held is not None and k != 0:
            engine = self.floor.engine
            self.held.hold(engine.site, engine.site.crews[self.floor.deciding],
                           self._decision.targets[k])
        return self._to_choice(self.floor.value_scope(self._decision.values(k)))

    def _to_choice(self, out: Outcome) -> Outcome:
        """Value decisions without a choice by Eq. 9 until one has a choice or the episode
        ends; the rewards add up."""
        reward = out.reward
        while not (out.terminated or out.truncated):
            engine, i = self.floor.engine, self.floor.deciding
            crew = engine.site.crews[i]
            values = self._held_values(engine, i)
            if values is None and has_choice(crew):
                self._decision = self.view.rows(crew, engine.site, engine.positions[i],
                                                engine.positions)
                return Outcome(reward, False, False)
            out = self.floor.value_scope(values if values is not None
                                         else self.view.base.values_for(engine, i))
            reward += out.reward
        if self.against_heuristic is not None:
            engine = self.floor.engine
            reward += terminal_term(engine.case.evaluation_reward.episode,
                                    self.heuristic_makespan_s(self._seed), engine.site.time_s,
                                    out.terminated, engine.max_time_s)
        return Outcome(reward, out.terminated, out.truncated)

    def _held_values(self, engine, i: int) -> dict[int, float] | None:
        """Crew i's values while it holds a choice (Eq. 9's, the held target promoted);
        None when it holds none or the loop holds nothing."""
        if self.held is None:
            return None
        site = engine.site
        return self.held.values(site, site.crews[i], self.view.base.values_for(engine, i))

    def heuristic_makespan_s(self, seed: int) -> float:
        """Eq. 9's makespan on ``seed`` (what row 0 at every decision plays), played once per
        seed on a floor of its own; an unfinished floor counts twice the time limit."""
        if seed not in self._heuristic_s:
            if self._reference is None:
                self._reference = self.against_heuristic()
            reference, eq9 = self._reference, self.view.base
            reference.reset(seed)
            out = Outcome(0.0, False, False)
            while not (out.terminated or out.truncated):
                engine, i = reference.engine, reference.deciding
                out = reference.value_scope(eq9.values_for(engine, i))
            self._heuristic_s[seed] = (engine.site.time_s if out.terminated
                                       else 2.0 * engine.max_time_s)
        return self._heuristic_s[seed]

    def observe(self, out: np.ndarray | None = None) -> np.ndarray:
        """The deciding crew's rows (made when the decision came up), into ``out`` if given."""
        if out is None:
            return self._decision.observation.copy()
        out[:] = self._decision.observation
        return out

    def action_masks(self) -> np.ndarray:
        return self._decision.mask.copy()

    def end_info(self) -> dict:
        return self.floor.end_info()
