"""The stage-2 high-level env: one step is one target evaluation (sections 3.6, 3.6.1).

``DecisionLoop`` is the stage-2 decision loop directly on an ``engine.Engine`` (no PettingZoo, no
agent names: crews are indices): the engine runs, with the low level's actions every second
(the scripted navigator or the stage-1 reaching policy), until a crew needs its target scope
valued; the policy's action values that crew's scope by Eq. 4. ``TargetEvaluationEnv`` is the
Gymnasium adapter over one floor (spaces, arrays). Training steps several floors per process
behind one SB3 vector env (``training.vec_env.FloorsVecEnv``), with the same floors.

Two floors (``fidelity``)
    ``"pymunk"`` (the default): the paper's floor, ``engine.Engine``, with a low level driving
    the crews every second between decisions. ``"event"``: the event floor
    (``eventfloor.EventFloor``), which jumps from event to event with no physics and no low
    level (crews walk the shortest path to their best target in the time Eq. 1 gives, times a
    walk factor), with the numbers ``calibration`` gives (a ``Calibration`` or its file; None:
    ``eventfloor.calibration_for`` the case, the built-in calibration where one was fitted on
    the same floor, else uncalibrated). It is a fast high-level benchmark and training floor:
    the same site, Table 1, paces, disruptions, R_e, observation and action spaces as the
    pymunk floor of the same case, so a model trained on one runs on the other. Its
    calibration is fitted on the pymunk floor; how closely it follows the pymunk floor
    (makespans, idle time per cause) is measured in docs/event-floor.md. Stage 1 (the low
    level's reaching policy: rays, contacts, R_r) needs the pymunk floor: the event floor has
    no low level, so ``make_low_level`` is not called there.

The registered Gymnasium ids (``registry.DECISION_VARIANTS``)
    ``gymnasium.make("cmdp/TargetEvaluation-v1")``: this env on the built-in case's pymunk
    floor, the scripted navigator as the low level (idle crews parked, as in training);
    ``gymnasium.make("cmdp/TargetEvaluationEvent-v1")``: the same env on the event floor with
    the case's calibration (``eventfloor.calibration_for``), about 40 times as many decisions
    a second (some 700 on one core here under random actions, against 16;
    ``benchmarks/bench_decision_env.py``). Both take
    ``make_decision_env``'s arguments as keyword overrides (``case=cmdp_pymunk.TINY_CASE``,
    ``max_time_s``, ``with_state``, ...).

Observation
    O^e of section 3.6.1 from the deciding crew's view (``observe.evaluation_observation``,
    the function deployment reads too): the crew's own 5 floats, then 12 floats for every
    potential target of the case, so the size is fixed (``Box(5 + 12 * n_targets)``, bounded
    by ``observe.evaluation_bounds(case)``). With ``with_state`` (a centralized critic), the
    global state s follows (``global_state``).

Action
    ``Box(-1, 1, (2,))``: the desired position (x/x_max, y/y_max); every target in the crew's
    scope gets V_Tar by Eq. 4 (``evaluate.desired_position_values``, the valuation deployment
    uses too), which the low level reads through Eq. 3.

When a decision is asked for (section 3.6)
    When a crew acquires a target scope, and after ``reevaluate_after_steps`` steps without
    reaching a target (``engine.pending``). A scope of one target leaves nothing to choose: it
    is valued 1 without asking the policy, and no transition enters the policy's buffer for it.

The formulation: one shared policy makes the team's decisions in sequence
    Several crews decide at different times. The policy is shared by every crew (the crew is
    told apart by O^e's own floats and the target-scope flags), and its decisions form one
    sequence in simulated time (a semi-Markov decision process over the team). The reward of
    a decision is the team's R_e (Eq. 5) summed over the simulated seconds from that decision
    to the next decision of any crew; two decisions at the same second leave the first one 0.
    PPO discounts by decision, not by second. Only real decisions enter the buffer: the
    simulation between two decisions is hidden inside ``step``.

Logistics decisions (``logistics=True``; off by default, and then every space is as above)
    Issue 42 item 6: the high level decides logistics too. A crew fetching at a storage whose
    stock falls to one of the decision levels (``logistics_levels``, shares of the material's
    crane lift: 0.75, 0.5 and 0.25 by default; ``logistics.Levels``) with no lift asked for
    is a decision of the same policy: ask for the next lift now, or let the stock run on to
    the next level or empty (the paper's c7). The engine asks through
    ``logistics.FromOutside``, and the case's reorder point gives way to the policy. The
    observation appends ``LOGISTICS_FEATURES`` floats to O^e (the actor reads them):
    whether this decision is a lift's (1) or a target choice's (0), the storage's stock over
    its capacity, the crane busy (1) and its queue over the number of crews; for a target
    choice all but the first are 0. The action is ``Box(-1, 1, (3,))``: the desired position
    (Eq. 4) as before, then the lift: above 0 asks for it now; a target choice ignores the
    third float and a lift decision the first two. Answering "no" to every lift decision
    plays the paper's c7 schedule (``tests/test_logistics.py``).

Episode end
    ``terminated`` when every task has ended. ``truncated`` at the time limit, or when no task
    moves on for ``stall_s`` simulated seconds (the engine's own stall guard: ``engine.stalled``
    says when, ``report.stall_report(floor.engine, ...)`` who and what): a stalled floor
    teaches nothing.

Info
    Empty but at an episode's end: ``makespan_s`` (None unless every task ended), ``stalled``,
    ``tasks_ended``, ``time_s``, ``episode_terms`` (R_e's terms summed over the episode) and
    ``idle_steps`` by cause.

Arguments (``DecisionLoop``)
    ``case``, ``make_low_level()`` (makes the ``policy.LowLevel``, which is then bound to the
    floor's engine; e.g. the class ``agents.navigator.Navigator``; None: the scripted
    navigator, ``DEFAULT_LOW_LEVEL``; not called on the event floor), ``fidelity``
    (``"pymunk"`` or ``"event"``; another name: a ValueError naming both), ``calibration``
    (the event floor's; see above), ``max_time_s`` (None: the case's), ``park_idle`` (see
    ``env``; for the scripted navigator), ``stall_s``, ``with_state``, ``logistics`` and
    ``logistics_levels`` (see Logistics decisions).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .. import observe
from ..cases.load import Case, as_case
from ..evaluate import desired_position_of_first_choice, desired_position_values
from ..eventfloor import Calibration, calibration_for, make_floor
from ..logistics import FromOutside
from ..policy import LowLevel
from ..reward import EVALUATION_TERMS
from .global_state import global_state, state_bounds

IDLE_CAUSES = ("predecessor", "area", "no_target")  # state.IdleCause's names
# what a logistics decision appends to O^e (see the module doc's Logistics decisions)
LOGISTICS_FEATURES = 4
# the pymunk floor's low level when none is given, loaded on use (the core imports no agents)
DEFAULT_LOW_LEVEL = "agents.navigator:Navigator"


def default_low_level() -> Callable[[], LowLevel]:
    """``make_low_level`` for the pymunk floor when none is given: the scripted navigator
    (``DEFAULT_LOW_LEVEL``)."""
    module, name = DEFAULT_LOW_LEVEL.split(":")
    return getattr(importlib.import_module(module), name)


@dataclass
class Outcome:
    """What a decision led to: R_e summed until the next decision, and how the episode
    stands."""

    reward: float
    terminated: bool
    truncated: bool


class DecisionLoop:
    """One stage-2 floor: decisions in, R_e out (see the module doc)."""

    def __init__(self, case: Case | str | Path | None,
                 make_low_level: Callable[[], LowLevel] | None = None, *,
                 fidelity: str = "pymunk", calibration: Calibration | str | Path | None = None,
                 max_time_s: float | None = None, park_idle: bool = False,
                 stall_s: float | None = 3600.0, with_state: bool = False,
                 logistics: bool = False,
                 logistics_levels: tuple[float, ...] = (0.75, 0.5, 0.25)):
        case_path = case if isinstance(case, (str, Path)) else None
        case = as_case(case)
        self.case = case
        if fidelity == "event" and not isinstance(calibration, Calibration):
            calibration = calibration_for(case, case_path, calibration)
        self.logistics = logistics
        self.engine = make_floor(case, fidelity, calibration, stage=2, evaluator=None,
                                 max_time_s=max_time_s, park_idle=park_idle, stall_s=stall_s,
                                 logistics=FromOutside(logistics_levels) if logistics else None)
        self.fidelity = fidelity
        self.low_level: LowLevel | None = None  # the event floor has none: crews walk
        if self.engine.motion.takes_actions:
            self.low_level = (make_low_level or default_low_level())()
            self.low_level.bind(self.engine)
        self.rays = observe.ReachingObservations(case) \
            if self.low_level is not None and self.low_level.reads_rays else None
        self.evaluation_bounds = observe.evaluation_bounds(case)
        self.actor_size = len(self.evaluation_bounds[0])
        if logistics:  # the actor reads the logistics floats too
            self.actor_size += LOGISTICS_FEATURES
        self.with_state = with_state
        self.state_bounds = state_bounds(case)
        low, high = self.evaluation_bounds
        if logistics:
            low = np.concatenate([low, np.zeros(LOGISTICS_FEATURES, np.float32)])
            high = np.concatenate([high, np.ones(LOGISTICS_FEATURES, np.float32)])
        if with_state:
            low = np.concatenate([low, self.state_bounds[0]])
            high = np.concatenate([high, self.state_bounds[1]])
        self.low, self.high = low, high
        self.deciding: int | None = None  # the crew whose scope the next action values
        # (crew, storage) whose lift the next action decides (``logistics``), else None
        self.deciding_lift: tuple[int, int] | None = None
        self.terms = dict.fromkeys(EVALUATION_TERMS, 0.0)  # R_e's terms over the episode

    # -- the decisions ------------------------------------------------------------------------

    def reset(self, seed: int) -> float:
        """A new episode on ``seed``, run to the first decision; returns R_e until then
        (credited to no decision)."""
        self.engine.reset(seed)
        if self.low_level is not None:
            self.low_level.reset(seed)
        if self.rays is not None:
            self.rays.reset()
        self.deciding = None
        self.deciding_lift = None
        self.terms = dict.fromkeys(EVALUATION_TERMS, 0.0)
        out = self._run()
        if out.terminated or out.truncated:  # a floor with nothing to choose: nothing to learn
            raise RuntimeError("the episode ended before any crew had a choice to make")
        return out.reward

    def decide(self, desired) -> Outcome:
        """The deciding crew's scope valued by Eq. 4 from ``desired`` (the action), then the
        floor runs on to the next decision or the episode's end. With ``logistics``, a lift
        decision reads the action's third float instead (above 0: lift now; ``lift``)."""
        if self.deciding_lift is not None:
            return self.lift(float(desired[2]) > 0.0)
        i = self.deciding
        if i is None:
            raise RuntimeError("decide() with no crew deciding: the episode has ended; call "
                               "reset(seed) first")
        return self.value_scope(desired_position_values(desired, self.engine.site.crews[i],
                                                        self.engine.site))

    def value_scope(self, values: dict[int, float]) -> Outcome:
        """The deciding crew's scope valued ``values`` (V_Tar per target), then the floor runs
        on to the next decision or the episode's end (``decide`` with Eq. 4; other action
        forms, such as the masked choice of ``agents.candidates``, give their values here)."""
        i = self.deciding
        if i is None:
            raise RuntimeError("value_scope() with no crew deciding: the episode has ended; "
                               "call reset(seed) first")
        self.deciding = None
        self.engine.set_target_values(i, values)
        return self._run()

    def lift(self, now: bool) -> Outcome:
        """The deciding crew's logistics decision: ask for its storage's next lift ``now`` or
        not (``Engine.answer_lift``), then the floor runs on to the next decision."""
        if self.deciding_lift is None:
            raise RuntimeError("lift() with no lift decision due: the next decision is a "
                               "target choice (decide / value_scope), or the episode has "
                               "ended")
        i, _ = self.deciding_lift
        self.deciding_lift = None
        self.engine.answer_lift(i, now)
        return self._run()

    @property
    def deciding_crew(self) -> int | None:
        """The crew whose decision (a target choice or a lift) the next action makes."""
        return self.deciding_lift[0] if self.deciding_lift is not None else self.deciding

    def _run(self) -> Outcome:
        """Advance with the low level until a crew must choose among several targets or the
        episode ends; R_e (Eq. 5, the team's) summed over the seconds run."""
        engine, reward = self.engine, 0.0
        while not self._next_decision():
            run = engine.advance(self._actions(), until=engine.decision_due)
            reward += sum(run.terms.values())
            for k, v in run.terms.items():
                self.terms[k] += v
            if run.terminated or run.truncated:
                return Outcome(reward, run.terminated, not run.terminated)
        return Outcome(reward, False, False)

    def _actions(self) -> list | None:
        """The low level's reaching actions for the coming second (on this second's rays if
        it reads them); None on the event floor, which has no low level."""
        if self.low_level is None:
            return None
        observations = self.rays.all(self.engine) if self.rays is not None else None
        return self.low_level.actions(self.engine, observations)

    def _next_decision(self) -> bool:
        """Take the next lift question (``logistics``), else the next crew asked that must
        choose among several targets; value lone targets 1."""
        engine = self.engine
        if engine.lift_questions:
            self.deciding_lift = engine.lift_questions[0]
            return True
        while engine.pending:
            i = engine.pending[0]
            scope = engine.site.crews[i].scope
            if len(scope) > 1:
                self.deciding = i
                return True
            engine.set_target_values(i, {t: 1.0 for t in scope})
        return False

    # -- what the policy reads ----------------------------------------------------------------

    def observe(self, out: np.ndarray | None = None) -> np.ndarray:
        """The deciding crew's O^e (then the global state with ``with_state``), into ``out``
        if given."""
        engine, i = self.engine, self.deciding_crew
        if out is None:
            out = np.empty(len(self.low), np.float32)
        size = len(self.evaluation_bounds[0])
        out[:size] = observe.evaluation_observation(
            engine.site, engine.site.crews[i], engine.positions[i], engine.pose(i)[2],
            self.evaluation_bounds)
        if self.logistics:
            out[size:self.actor_size] = self.logistics_features()
        if self.with_state:
            out[self.actor_size:] = self.state()
        return out

    def logistics_features(self) -> np.ndarray:
        """The ``LOGISTICS_FEATURES`` floats (see the module doc's Logistics decisions)."""
        out = np.zeros(LOGISTICS_FEATURES, np.float32)
        if self.deciding_lift is None:
            return out
        site = self.engine.site
        storage, crane = site.storages[self.deciding_lift[1]], site.crane
        out[:] = (1.0, min(1.0, storage.stock / storage.capacity),
                  float(crane.current is not None), min(1.0, len(crane.queue) / len(site.crews)))
        return out

    def state(self) -> np.ndarray:
        """The global state s (``global_state``), clipped into its bounds."""
        engine = self.engine
        out = global_state(engine.site, engine.positions, engine.headings(), engine.max_time_s)
        return np.clip(out, *self.state_bounds, out=out)

    def teacher_action(self) -> np.ndarray:
        """The priority heuristic's choice (Eq. 9) for the deciding crew as a desired
        position, so that Eq. 4 ranks its target first; with ``logistics``, then -1: the
        paper's answer to a lift decision (never early, c7)."""
        engine, i = self.engine, self.deciding
        if i is None:  # a lift decision: the desired position is not read
            return np.array([0.0, 0.0, -1.0], np.float32)
        desired = desired_position_of_first_choice(engine.site.crews[i], engine.site,
                                                   engine.positions[i])
        return np.array((*desired, -1.0) if self.logistics else desired, np.float32)

    def end_info(self) -> dict:
        """The episode's end (see the module doc's Info)."""
        site = self.engine.site
        idle = dict.fromkeys(IDLE_CAUSES, 0)
        for crew in site.crews:
            for cause, steps in crew.stats.idle_steps.items():
                if steps or cause.name.lower() in idle:  # a disruption's cause only if it hit
                    idle[cause.name.lower()] = idle.get(cause.name.lower(), 0) + steps
        return {"makespan_s": self.engine.makespan_s, "stalled": self.engine.stalled is not None,
                "tasks_ended": site.tasks_ended, "time_s": site.time_s,
                "episode_terms": dict(self.terms), "idle_steps": idle}


class TargetEvaluationEnv(gym.Env):
    """One step = one target evaluation by the shared high-level policy, on ``floor`` (see
    the module doc)."""

    metadata = {"render_modes": []}

    def __init__(self, floor: DecisionLoop):
        self.floor = floor
        self.observation_space = spaces.Box(floor.low, floor.high, dtype=np.float32)
        # with logistics decisions a third float: lift now (above 0) or not
        self.action_space = spaces.Box(-1.0, 1.0, (3 if floor.logistics else 2,), np.float32)

    def reset(self, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is None:  # one generator for the whole run, drawn from gymnasium's
            seed = int(self.np_random.integers(2**31))
        self.floor.reset(seed)
        return self.floor.observe(), {}

    def step(self, action):
        out = self.floor.decide(action)
        if out.terminated or out.truncated:
            return np.zeros(self.observation_space.shape, np.float32), out.reward, \
                out.terminated, out.truncated, self.floor.end_info()
        return self.floor.observe(), out.reward, False, False, {}


def make_decision_env(case: Case | str | Path | None = None, fidelity: str = "pymunk",
                      calibration: Calibration | str | Path | None = None,
                      make_low_level: Callable[[], LowLevel] | None = None,
                      max_time_s: float | None = None, park_idle: bool = True,
                      stall_s: float | None = 3600.0,
                      with_state: bool = False, logistics: bool = False,
                      logistics_levels: tuple[float, ...] = (0.75, 0.5, 0.25)
                      ) -> TargetEvaluationEnv:
    """The stage-2 Gymnasium env on one floor (the registered ids' entry point, see the module
    doc): ``DecisionLoop``'s arguments; ``park_idle`` True by default, as training parks the
    scripted navigator's idle crews (the event floor has no low level and ignores it)."""
    return TargetEvaluationEnv(DecisionLoop(
        case, make_low_level, fidelity=fidelity, calibration=calibration,
        max_time_s=max_time_s, park_idle=park_idle, stall_s=stall_s, with_state=with_state,
        logistics=logistics, logistics_levels=logistics_levels))
