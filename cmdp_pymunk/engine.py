"""The CMDP engine: one episode of a case, advanced second by second (section 3.2).

The engine knows nothing of PettingZoo, Gymnasium or SB3. Crews are indices (the case's
order), a reaching action is a triple of ``move.ACTION_NVEC`` per crew, and the engine says
what it needs from outside:

- ``needs_action(crew)`` / ``action_needed``: which crews need a movement decision now;
- ``pending``: which crews' target scopes wait for values, when no evaluator is injected
  (``evaluator=None``: values come from outside, at every layer); answer with
  ``set_target_values(i, values)``.

Evaluators (``evaluate.TargetEvaluator``) are asked ``values_for(self, i)`` for each crew whose
scope needs values: inside the second, or once it is whole for one that branches the floor
(``between_seconds``). Low levels keep their per-episode state in ``memory`` (a dict by the low
level's name), so that ``clone`` carries it and a branch continues as the original would.

``reset(seed)`` starts an episode (its random streams, ``streams``, keyed here: a task's pace
by seed and task); ``step(actions)`` runs one span and returns what happened (``motion.Span``:
one simulated second on the physics motion, the seconds to the next event on the walk motion);
``advance(actions, until)`` runs spans until a condition holds, the episode ends or it is cut
(the idle jump, generalised), and counts them for metrics
(``metrics.Counters``, beside the dynamics). Observations are the adapters' business
(``observe``): the PettingZoo env (``env.CMDPEnv``) casts the rays, the stage-2 env
(``adapters.decision_loop``) builds O^e.

One second, in the paper's order (section 3.2)
    At second t the crews decided (Pi_cons, Table 1), their scopes were valued (Eq. 4 or
    Eq. 9) and they observed (Eq. 3) at the end of the previous second, or in ``reset``; the
    reaching actions chosen on those observations then move the crews (P_phy, Eq. 1),
    construction advances (P_cons, Eq. 2), and the state s_{t+1} is decided, valued and
    rewarded (R_r, Eqs. 6-7; R_e's terms, Eq. 5).

Arguments
    ``case``, ``stage`` (1: section 4.2's simplified CMDP; 2: the full CMDP), ``evaluator``
    (``evaluate.TargetEvaluator`` or a name of ``evaluate.EVALUATORS``; None: values come from
    outside), ``max_time_s`` (None: the
    case's), ``park_idle`` and ``stall_s`` (see ``env``), ``position_log_every_s`` (position
    events for trajectories; None: none), ``physics`` (what builds an episode's plane from the
    case and the site, a ``physics.Physics``; default pymunk's ``world.World``),
    ``logistics`` (``logistics.Logistics``: when a fetching crew asks for the next lift; None:
    the case's reorder point, else c7 alone, the paper's).

The engine owns the floor: its site (``site``), the plane behind the ``physics.Physics``
protocol (only the engine and its stages touch it), the crews' poses (``pose(i)``), the event
log and the counters. Policies, evaluators, the renderer and the episode library read them here
and address crews by index; agent names live only in the PettingZoo adapter.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import construct, decide, disruptions, events, move, reward
from .cases.model import Case
from .evaluate import TargetEvaluator, crews_needing_values, make_evaluator
from .logistics import Logistics, make_logistics
from .metrics import Counters
from .motion import Motion, PhysicsMotion, Second, Span
from .physics import Physics
from .state import CrewState, Site, activity
from .streams import RandomStreams


@dataclass
class Advance:
    """What ``Engine.advance`` did: seconds run, R_r per crew and R_e's terms summed over
    them, and how the episode stands."""

    elapsed: int = 0
    rewards: list[float] = field(default_factory=list)
    terms: dict[str, float] = field(default_factory=lambda: dict.fromkeys(
        reward.EVALUATION_TERMS, 0.0))
    terminated: bool = False  # every task has ended
    truncated: bool = False  # the time limit or the stall guard cut the episode

    def add(self, span: Span) -> None:
        """One span: its seconds, R_r, and R_e's terms, held through all but its last
        second (nothing changes between the spans' ends) and as they stand at its end."""
        k = span.seconds
        self.elapsed += k
        if any(span.rewards):  # none on a motion without actions: adding 0.0 changes nothing
            for i, r in enumerate(span.rewards):
                self.rewards[i] += r
        if k == 1:
            for name, v in span.terms.items():
                self.terms[name] += v
        else:
            for name, v in span.terms_before.items():
                self.terms[name] += v * (k - 1) + span.terms[name]


class Engine:
    """One episode of the CMDP (see the module doc)."""

    def __init__(self, case: Case, stage: int = 2,
                 evaluator: TargetEvaluator | str | None = None,
                 seed: int | None = None, max_time_s: float | None = None,
                 park_idle: bool = False, stall_s: float | None = None,
                 position_log_every_s: float | None = None, *,
                 physics: Callable[[Case, Site], Physics] | None = None,
                 motion: Motion | None = None, logistics: Logistics | None = None):
        if stage not in (1, 2):
            raise ValueError(f"stage must be 1 (section 4.2's simplified CMDP) or 2 (the full "
                             f"CMDP), not {stage!r}")
        self.case = case
        self.stage = stage
        self._evaluator: TargetEvaluator | None = None
        self.evaluator = evaluator  # checked against the case (``prepare``)
        self._logistics: Logistics | None = None
        self.logistics = logistics  # likewise
        sim = case.simulation
        self.max_time_s = float(max_time_s if max_time_s is not None else sim.max_time_s)
        if not math.isfinite(self.max_time_s) or self.max_time_s <= 0:
            raise ValueError(f"max_time_s must be a positive finite number of seconds, not "
                             f"{self.max_time_s!r}")
        if stall_s is not None and not (math.isfinite(stall_s) and stall_s > 0):
            raise ValueError(f"stall_s must be a positive finite number of seconds or None "
                             f"(no stall guard), not {stall_s!r}")
        self.stall_s = stall_s
        self.stalled: dict | None = None
        self.park_idle = park_idle
        self.position_log_every_s = position_log_every_s
        self.eta = reward.eta_by_kind(case.reaching_reward)
        self.streams = RandomStreams(seed)  # a task's pace by (seed, task): streams.py
        self.timeline: disruptions.Timeline | None = None  # the case's, drawn in reset
        if motion is not None and physics is not None:
            raise ValueError("give the plane either as physics= (the physics motion's plane) "
                             "or inside motion=, not both")
        self.motion: Motion = motion if motion is not None else PhysicsMotion(physics)
        self.motion.check(self)
        # The episode's state: set by ``reset``, None or empty before the first one.
        self.site: Site | None = None
        self.world: Physics | None = None
        self.log = events.EventLog()
        self.metrics: Counters | None = None
        self.pending: list[int] = []  # crews whose scopes wait for values
        # (crew, storage) asked whether to lift now, waiting for an answer from outside
        # (``logistics.FromOutside``; ``answer_lift``)
        self.lift_questions: list[tuple[int, int]] = []
        # parked crews a low level moves out of another crew's way, until when (``make_way``)
        self.making_way: dict[int, float] = {}
        self.action_needed = False  # some crew needs a movement decision
        self.positions: list[tuple[float, float]] = []  # every crew's (x, y), crew order
        self.activities: list[str] = []  # every crew's Gantt category (Fig. 9), as logged
        self.steps = 0  # simulated seconds (steps) run this episode
        self.spans_run = 0  # spans run this episode (seconds on the physics motion, events
        # on the walk motion: the speed benchmarks' count)
        self.memory: dict[str, Any] = {}  # the low levels' per-episode state (module doc)
        self._last_logged: list = []
        self._no_rewards: list[float] = []
        self.progress_mark: tuple = (0.0, (0, 0.0))
        self._terms: dict[str, float] = dict.fromkeys(reward.EVALUATION_TERMS, 0.0)
        self._construct_logged = False

    @property
    def evaluator(self) -> TargetEvaluator | None:
        """What values the crews' scopes (``evaluate.TargetEvaluator``); None: values come
        from outside (``pending`` / ``set_target_values``). Set it to an evaluator or a name
        of ``evaluate.EVALUATORS``: it is prepared for the case (a misfit raises here)."""
        return self._evaluator

    @evaluator.setter
    def evaluator(self, value: TargetEvaluator | str | None) -> None:
        if value is not None:
            value = make_evaluator(value)
            value.prepare(self.case)
        self._evaluator = value

    @property
    def logistics(self) -> Logistics | None:
        """Who decides when a fetching crew asks for the next lift (``logistics.Logistics``);
        None: the case's reorder point (``Material.reorder_at``), else c7 alone. Set it to a
        role: it is prepared for the case (a misfit raises here)."""
        return self._logistics

    @logistics.setter
    def logistics(self, value: Logistics | None) -> None:
        value = make_logistics(value)
        if value is not None:
            value.prepare(self.case)
        self._logistics = value

    @property
    def lift_levels(self) -> Callable[[str], tuple[float, ...]] | None:
        """The logistics role's decision levels by material, where the walk motion stops a
        span (``construct.next_change_in``); None: the case's reorder point's."""
        return None if self._logistics is None else self._logistics.levels

    # -- an episode ---------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """A new episode; ``seed`` re-keys the random streams (None keeps them, and returns
        to the floor's own future). The crews decide and are valued for the first second."""
        self.streams = RandomStreams(seed) if seed is not None else \
            self.streams.with_scenario(None)
        self.site = Site(self.case, self.stage)
        self.world = self.motion.plane(self.case, self.site)
        self.spans_run = 0
        self.motion.begin(self)
        self.log = events.EventLog()
        self.metrics = Counters(self.site)
        # Disruptions (their own streams): none in the case, no timeline, nothing changes.
        self.timeline = disruptions.Timeline(self.case, self.streams, self.max_time_s) \
            if self.case.disruptions else None
        if self.stage == 1:  # unrestricted stockpiles (section 5.2): storages start full and
            for storage in self.site.storages:  # are never drawn down; crews still fetch
                storage.stock = storage.capacity
        for crew in self.site.crews:
            self.log.add(0.0, "crew_state", crew.id, crew.status.name.lower())
        n = len(self.site.crews)
        self.activities = [""] * n
        self._last_logged = [None] * n
        self._no_rewards = [0.0] * n
        self.positions = [self.world.pose(i)[:2] for i in range(n)]
        self.memory = {}
        self.steps = 0
        self.stalled = None
        self.progress_mark = (0.0, self.task_progress())
        if self.timeline is not None:  # one at time 0 strikes before the first decisions
            disruptions.update(self.site, self.world, self.log, self.timeline)
        decide.apply_decision_table(self.context())
        self.pending = []
        self.lift_questions = []
        self.making_way = {}
        self._evaluate()
        if self.timeline is not None:
            disruptions.refresh_causes(self.site)
        self._log_activities()
        self._log_positions()
        self.action_needed = any(self.needs_action(c) for c in self.site.crews)
        self._terms = reward.evaluation_reward_terms(self.site, self.case.evaluation_reward)
        self._value_between_seconds()
        self.motion.replan(self)

    def step(self, actions=None) -> Span:
        """One span in the paper's order (see the module doc): one second on the physics
        motion, to the next event on the walk motion. ``actions[i]``: crew i's reaching
        action, used only if it moves (ignored by a motion that takes none)."""
        if self.site is None:
            raise RuntimeError("step: the engine has no episode yet; call reset(seed) first")
        if self.motion.takes_actions:
            crews = self.site.crews
            if actions is None or len(actions) != len(crews):
                given = "no" if actions is None else len(actions)
                raise ValueError(f"step: {given} reaching actions for {len(crews)} crews; "
                                 "fix: give one action per crew, in the case's crew order (a "
                                 "crew that does not move ignores its own, e.g. "
                                 f"{move.STAND_STILL})")
        return self._span(actions, self.motion.span_s(self))

    def _span(self, actions, k: int) -> Span:
        """``k`` seconds: P_phy by the motion, P_cons for the span, disruptions, Table 1 and
        the evaluation, the log, R_r and R_e's terms; written once for every motion."""
        site, motion = self.site, self.motion
        crews = site.crews
        n = len(crews)
        self.spans_run += 1
        moving = [c.moving for c in crews]
        span = Span(k, moving, [m and bool(c.scope) for m, c in zip(moving, crews, strict=True)],
                    [0.0] * n, [None] * n, self._no_rewards, terms_before=self._terms,
                    timeouts=[0] * n, disrupted=bool(site.disrupted))
        quiet = motion.quiet(self)
        if not quiet:
            self._move(actions, span)                                   # P_phy, Eq. 1
        ctx = self._construct(k)                                        # P_cons, Eq. 2
        disrupted = self._disrupt()           # disruptions starting or ending (not the paper's)
        # A quiet second where no row but c2 (tasks progress) would fire: the decisions, the
        # evaluation and R_r would change nothing, so they are skipped.
        skip = quiet and not disrupted and decide.only_execution_fires(ctx)
        if not skip:
            self._decide(ctx)                           # Pi_cons, Table 1; V_Tar, Eq. 4 or 9
        # What the activities and R_e read (statuses, scopes, idle causes, tasks ended) changed
        # only if the table ran or P_cons logged a change (the crane wakes a waiting crew).
        changed = not skip or self._construct_logged
        if self.timeline is not None and disruptions.refresh_causes(site):
            changed = True
        self._log_events(span.moving, changed)
        if motion.takes_actions:
            span.contacts, span.rewards = self._reaching_rewards(ctx, span, skip)  # Eqs. 6-7
        if changed:                                                     # R_e's terms, Eq. 5
            self._terms = reward.evaluation_reward_terms(site, self.case.evaluation_reward)
        span.terms = self._terms
        motion.end_span(self, span, ctx)          # section 3.6's clocks; the walks
        return span

    def advance(self, actions, until: Callable[[], bool] | None = None) -> Advance:
        """Run seconds with ``actions`` until ``until()`` holds after one (None: one
        second), every task has ended, or the time limit or the stall guard cuts the episode.
        Each second is counted for metrics (``self.metrics``; its window covers this call)."""
        if self.pending:
            raise RuntimeError(f"crews {self.pending} wait for target values; call "
                               "set_target_values for each first")
        if self.lift_questions:
            raise RuntimeError(f"crews {[i for i, _ in self.lift_questions]} wait for an "
                               "answer whether to lift now; call answer_lift for each first")
        site, motion = self.site, self.motion
        out = Advance(rewards=[0.0] * len(site.crews))
        self.metrics.open_window()
        motion.replan(self)  # values may have come from outside
        while True:
            span = self.step(actions)
            self.metrics.count(span)
            out.add(span)
            truncated = site.time_s >= self.max_time_s - 1e-9 or self._stall_check()
            if site.done or truncated or until is None or until() or self.pending or \
                    self.lift_questions:
                break  # pending: an evaluator asked between seconds values them
        self.metrics.close_window()
        out.terminated = site.done
        out.truncated = truncated
        if not (out.terminated or out.truncated):
            self._value_between_seconds()
            motion.replan(self)
        return out

    def run(self) -> Advance:
        """To the end of the episode (every task ended, the time limit or the stall guard) on
        a motion that takes no reaching actions (the walk motion), valuing between spans if
        the evaluator asks so. A motion with actions needs its low level:
        ``rollout.play(engine, low_level)``."""
        if self.motion.takes_actions:
            raise ValueError(f"run: the {self.motion.name} motion moves crews by reaching "
                             "actions; fix: drive it with a low level, "
                             "rollout.play(engine, low_level)")
        total = Advance(rewards=[0.0] * len(self.site.crews))
        while True:
            part = self.advance(None, until=_never)
            total.elapsed += part.elapsed
            for k, v in part.terms.items():
                total.terms[k] += v
            if part.terminated or part.truncated:
                total.terminated, total.truncated = part.terminated, part.truncated
                return total

    def clone(self, scenario: int | None = None, keep_log: bool = True,
              motion: Motion | None = None) -> Engine:
        """An independent episode at the same second: a branch of the floor.

        Everything is copied (site, world, event log, counters, streams, the motion and its
        per-episode state, the low levels' ``memory``) but the case and the injected
        evaluator, which are shared (an evaluator must keep no state of its own per
        episode). ``scenario``: None keeps the floor's own future (the clone, given the same
        actions and values, runs exactly as the original); an int draws the paces of tasks
        not yet started from that sampled future (``streams``), keeping those already drawn.
        A low level that keeps its per-episode state in ``memory`` drives the clone as it
        would the original. ``keep_log`` False: the clone starts an empty event log and logs
        no positions (a lookahead branch needs only the makespan; copying a long log costs
        more than the rest).

        ``motion``: the branch moves its crews by this motion from here on (e.g. the walk
        motion, ``eventfloor.WalkMotion``: a planner thinks on the event floor and acts on the
        pymunk one): its plane is built anew from the site with the crews where they stand;
        the low levels' memory is left behind.

        pymunk's contact cache cannot be copied, so the original's world is rebuilt from
        the same data as the clone's: both continue identically, and the original may
        differ in the last digits of a contact from a run that never branched.
        """
        if self.site is None:
            raise RuntimeError("clone: the engine has no episode yet; call reset(seed) first")
        if self.site.done:
            raise ValueError("clone: the episode has ended (every task is done); there is no "
                             "future to branch")
        memo = {id(self.case): self.case}
        if not keep_log:
            memo[id(self.log)] = events.EventLog()
        if self.evaluator is not None:
            memo[id(self.evaluator)] = self.evaluator
        if self._logistics is not None:  # shared like the evaluator: no per-episode state
            memo[id(self._logistics)] = self._logistics
        if motion is not None:  # neither the plane nor the motion's state is carried
            memo[id(self.world)] = None
            memo[id(self.motion)] = motion
            memo[id(self.memory)] = {}
        branch = copy.deepcopy(self, memo)
        if not keep_log:
            branch.position_log_every_s = None
        if motion is None:
            self.world.rebuild()
        else:
            branch._join(motion, self)
        branch.streams.with_scenario(scenario if scenario is not None
                                     else self.streams.scenario)
        if scenario is not None and branch.timeline is not None:  # its own future's
            branch.timeline.resample(branch.streams, self.site.time_s)  # disruptions
        return branch

    def _join(self, motion: Motion, source: Engine) -> None:
        """This branch of ``source`` goes on by ``motion``: a new plane, crews placed where
        they stand, the motion's per-episode state begun and its first plan made."""
        motion.check(self)
        self.world = motion.plane(self.case, self.site)
        place = getattr(self.world, "place", None)  # not every plane takes crews mid-episode
        if place is None:
            raise ValueError(f"clone: the {motion.name} motion's plane cannot place crews in an "
                             "episode under way; fix: branch onto it from reset, or give its "
                             "plane a place(i, xy, heading)")
        for i in range(len(self.site.crews)):
            x, y, heading = source.pose(i)
            place(i, (x, y), heading)
        self.spans_run = 0
        self.making_way = {}
        self.action_needed = any(self.needs_action(c) for c in self.site.crews)
        motion.begin(self)
        motion.replan(self)

    def quiet(self) -> bool:
        """Nothing moves in the coming second and no crew needs a movement decision: P_phy
        is void in it (``Motion.quiet``)."""
        return self.motion.quiet(self)

    def decision_due(self) -> bool:
        """A crew needs a movement decision, target values or an answer whether to lift now:
        where the idle jump stops."""
        return self.action_needed or bool(self.pending) or bool(self.lift_questions)

    # -- what the engine needs from outside ---------------------------------------------------

    def needs_action(self, crew: CrewState) -> bool:
        """Whether the crew's reaching action is used in the coming span (section 3.6.2;
        the motion's rule: ``Motion.needs_action``)."""
        return self.motion.needs_action(self, crew)

    def make_way(self, i: int, until_s: float) -> None:
        """Let crew i, parked (``park_idle``: no target, standing still), take reaching
        actions until ``until_s``: a low level moves it out of the way of a crew it blocks
        (a crew on site asks a gang standing in a passage to step aside). Without
        ``park_idle`` every reaching crew takes them anyway."""
        self.making_way[i] = until_s

    def set_target_values(self, i: int, values: dict[int, float]) -> None:
        """V_Tar for crew i's target scope, from outside (e.g. the stage-2 policy by Eq. 4):
        one value per target of ``crew.scope``; Eq. 3 puts them into the crew's rays. Only a
        crew the engine asks for (``pending``) may be valued: a ValueError names them."""
        crews = self.site.crews
        if i not in self.pending:
            asked = ", ".join(f"{j} ({crews[j].id})" for j in self.pending) or "none"
            raise ValueError(f"crew {i} ({crews[i].id}) was not asked for target values; the "
                             f"engine asks for crews: {asked}; fix: value only crews in "
                             "engine.pending")
        crew = crews[i]
        if values.keys() != crew.scope.keys():
            raise ValueError(f"{crew.id}: values for targets {sorted(values)}, but its scope is "
                             f"{sorted(crew.scope)}; fix: give one value per target in scope")
        crew.values = dict(values)
        self.pending.remove(i)

    def answer_lift(self, i: int, lift: bool) -> None:
        """The answer from outside to crew i's question whether to ask for its storage's next
        lift now (``lift_questions``, asked by ``logistics.FromOutside``): "yes" asks the
        crane at this second (``construct.order_lift``), as a role answering inside the span
        would; "no" lets the stock run on. Only a crew asked may answer: a ValueError names
        them."""
        asked = [q for q in self.lift_questions if q[0] == i]
        if not asked:
            crews = self.site.crews
            waiting = ", ".join(f"{j} ({crews[j].id})" for j, _ in self.lift_questions) or \
                "none"
            raise ValueError(f"crew {i} ({crews[i].id}) was not asked whether to lift now; the "
                             f"engine asks crews: {waiting}; fix: answer only crews in "
                             "engine.lift_questions")
        self.lift_questions.remove(asked[0])
        storage = self.site.storages[asked[0][1]]
        if lift and not storage.lift_pending:
            construct.order_lift(self.site, self.log, self.site.crews[i], storage)

    def pose(self, i: int) -> tuple[float, float, float]:
        """Crew i's pose on the plane: x, y (m, the plane's centre at 0) and heading (rad,
        counter-clockwise from +x). What policies, the renderer and reports read, so that
        only the engine touches the plane (``physics.Physics``)."""
        return self.world.pose(i)

    def headings(self) -> list[float]:
        """Every crew's heading (rad), in crew order (what the global state reads)."""
        return [self.world.pose(i)[2] for i in range(len(self.site.crews))]

    @property
    def makespan_s(self) -> float | None:
        """Simulated seconds until the last task ended, once every task has."""
        return self.site.time_s if self.site is not None and self.site.done else None

    # -- the stages ---------------------------------------------------------------------------

    def context(self) -> decide.Context:
        return decide.Context(self.site, self.world, self.positions, self.streams, self.log)

    def _move(self, actions, span: Span) -> None:
        """P_phy over the span, by the motion (``Motion.move``)."""
        self.motion.move(self, actions, span)

    def _construct(self, k: int = 1) -> decide.Context:
        """The clock moves on ``k`` steps and P_cons advances the tasks, fetches and the crane
        through them (every rate is constant within a span); returns the context the decision
        table will read."""
        logged = len(self.log.events)
        dt = k * self.case.simulation.step_s
        self.site.time_s += dt
        self.steps += k
        role = self._logistics
        construct.advance(self.site, self.positions, self.log, dt, self.motion.invasion_of,
                          None if role is None else _LiftQuestion(self, role))
        self._construct_logged = len(self.log.events) != logged
        return self.context()

    def _disrupt(self) -> bool:
        """Disruptions for the second that starts now (``disruptions.update``): whether one
        started or ended. Then the decisions run and every crew is asked again who moves."""
        if self.timeline is None:
            return False
        if not disruptions.update(self.site, self.world, self.log, self.timeline):
            return False
        self._construct_logged = True
        return True

    def _log_events(self, moving, changed: bool) -> None:
        """Activity changes (if anything they read changed) and moving crews' positions."""
        if changed:
            self._log_activities()
        if any(moving):
            self._log_positions()

    def _decide(self, ctx: decide.Context) -> None:
        """Pi_cons (Table 1), then the target evaluation of the scopes it changed."""
        decide.apply_decision_table(ctx)
        self._evaluate()

    def _evaluate(self) -> None:
        """Target evaluation (section 3.6): by the injected evaluator, or left pending (no
        evaluator, or one that is asked between seconds)."""
        evaluator = self._evaluator
        if evaluator is None or evaluator.between_seconds:
            self.pending = [c.index for c in crews_needing_values(self.site)]
        else:
            for crew in crews_needing_values(self.site):
                crew.values = dict(evaluator.values_for(self, crew.index))

    def _value_between_seconds(self) -> None:
        """An evaluator asked between seconds values the pending scopes once the second is
        whole (it may clone the engine meanwhile)."""
        if self._evaluator is None or not self._evaluator.between_seconds:
            return
        while self.pending:
            i = self.pending[0]
            self.set_target_values(i, self.evaluator.values_for(self, i))

    def _reaching_rewards(self, ctx: decide.Context, span: Span,
                          skip: bool) -> tuple[list, list[float]]:
        """Every crew's contacts and R_r this second, Eqs. 6-7 (0 for a crew that did not
        move); then who needs a movement decision next. In a skipped second nothing moved
        (no contacts), nothing was reached and no crew held a target: R_r is 0."""
        moving, had_target = span.moving, span.had_target
        if skip:
            return [None] * len(moving), self._no_rewards
        contacts = [self.world.take_contacts(c.index) for c in self.site.crews]
        weights = self.case.reaching_reward
        rewards = [reward.reaching_reward(contacts[i], self.eta, ctx.reached_value.get(i),
                                          had_target[i], weights) if moving[i] else 0.0
                   for i in range(len(moving))]
        self.action_needed = any(self.needs_action(c) for c in self.site.crews)
        return contacts, rewards

    # -- the stall guard ----------------------------------------------------------------------

    def task_progress(self) -> tuple[int, float]:
        """What the stall guard watches: tasks ended and the progress of those on."""
        site = self.site
        return site.tasks_ended, sum(site.tasks[t].progress for t in site.active_areas)

    def _stall_check(self) -> bool:
        """True once no task has moved on for ``stall_s``; records ``self.stalled``."""
        if self.stall_s is None or self.site.done:
            return False
        now = self.site.time_s
        progress = self.task_progress()
        # A disruption under way (a long repair, a weather stop) is no stall: its time is not
        # counted, and the guard starts again once it is over.
        if progress != self.progress_mark[1] or self.site.disrupted:
            self.progress_mark = (now, progress)
            return False
        if now - self.progress_mark[0] < self.stall_s - 1e-9:
            return False
        self.stalled = {"after_s": now - self.progress_mark[0], "time_s": now}
        return True

    # -- the event log ------------------------------------------------------------------------

    def _log_activities(self) -> None:
        """An ``activity`` event whenever a crew's Gantt category (Fig. 9) changes."""
        for crew in self.site.crews:
            now = activity(crew)
            if now != self.activities[crew.index]:
                self.activities[crew.index] = now
                self.log.add(self.site.time_s, "activity", crew.id, now)

    def _log_positions(self) -> None:
        """``position`` events (subject "x,y,heading_deg") of crews that moved, for
        trajectories: when the motion says one is due (every ``position_log_every_s`` on the
        physics motion, at each event on the walk motion); a crew standing still logs
        nothing."""
        if self.position_log_every_s is None:
            return
        due = self.motion.position_due
        for crew in self.site.crews:
            if crew.moving and due(self, crew):
                self._log_position(crew)

    def _log_position(self, crew: CrewState) -> None:
        """One ``position`` event of the crew at its pose, unless it has moved less than
        5 cm since the last one it logged."""
        x, y, heading = self.world.pose(crew.index)
        last = self._last_logged[crew.index]
        if last is not None and abs(x - last[0]) + abs(y - last[1]) < 0.05:
            return
        self._last_logged[crew.index] = (x, y)
        self.log.add(self.site.time_s, "position", crew.id,
                     f"{x:.2f},{y:.2f},{math.degrees(heading) % 360:.0f}")


def _never() -> bool:
    return False


class _LiftQuestion:
    """The logistics role bound to its engine: what ``construct.advance`` asks
    (``construct.LiftQuestion``). Made per span, so a clone never asks the original."""

    __slots__ = ("engine", "role")

    def __init__(self, engine: Engine, role: Logistics):
        self.engine, self.role = engine, role

    def levels(self, material: str) -> tuple[float, ...]:
        return self.role.levels(material)

    def lift_now(self, crew: int, storage: int) -> bool:
        return bool(self.role.lift_now(self.engine, crew, storage))


__all__ = ["Engine", "Advance", "Second", "Span"]
