"""The CMDP as a PettingZoo ``ParallelEnv``: one agent per crew, the tower crane shared.

Agents
    One per crew of the case (``"JCC-1"``, ``"HIC-1"``... in the built-in case). Crews stay in
    ``agents`` until the episode ends; a crew that has left, or that tasks, fetches or waits,
    gets a constant all-zero observation and ignores its action.

Observation space (reaching policy, section 3.6.2)
    ``Box(115,)`` for 12 frontal + 16 surrounding rays: 4 values a ray (relative length,
    emission angle, type id, priority value after Eq. 3) and the crew's velocity (forward,
    left, speed). With the case's ``target_memory`` on (beyond the paper; the built-in case
    has it), 4 more floats say where the crew last saw a target of its scope: ``Box(119,)``.
    See ``observe`` for the exact layout and what rays see of sensor areas. Every float is
    bounded (``observe.observation_bounds``): lengths, type ids and priorities in [0, 1],
    angles in [-1, 1], velocities within the case's speed cap, memory offsets within the
    plane's diagonal over the sight distance.

Action space
    ``MultiDiscrete([4, 3, 3])``: forward {0, 0.3, 0.8, 1} x v_f, lateral {-1, 0, 1} x v_l,
    turn {-1, 0, 1} x v_tu, each first reduced by Eq. 1 (``move``).

Rewards
    The reaching reward R_r of Eqs. 6-7 (collisions and congestion entries weighted by eta per
    object kind, k x V_Tar on reaching a target, a small time penalty while holding a target).
    The evaluation reward R_e of Eq. 5 is in ``infos[agent]["evaluation_reward"]`` with its
    terms in ``infos[agent]["evaluation_terms"]``, for the high-level policy.

Stages (section 4.2)
    ``stage=1``: task durations zero, unrestricted stockpiles (storages are full and never
    drawn down, a fetch loads the crew at once), no crane wait. Crews still use up their loads
    and walk to the storages, so the reaching policy meets every kind of target it meets in
    stage 2. ``stage=2``: the full CMDP.

Arguments
    ``case``: a ``Case``, a path to a case file, or ``None`` for the built-in case.
    ``stage``: 1 or 2. ``seed``: seeds the episode generator (``reset(seed)`` re-seeds it,
    ``reset()`` keeps it). ``evaluator``: fills V_Tar (default nearest-first; the priority
    heuristic and the stage-2 model are injected the same way). ``render_mode``: ``None`` or
    ``"rgb_array"``. ``jump_idle``: when no crew needs a movement decision (all tasking,
    fetching, waiting or gone), one ``step`` call runs on to the next second at which one does;
    ``infos[agent]["elapsed_s"]`` says how far. ``max_time_s`` overrides the case's time limit.
    ``park_idle``: a crew without a target that stands outside every task area and storage is
    parked: it stands still, needs no movement decision and does not hold up the idle jump (the
    paper lets such crews manoeuvre; a scripted low level that only parks them runs faster this
    way). Default False.
    ``position_log_every_s``: log moving crews' positions to the event log this often (for
    trajectory charts); ``None`` logs none. ``lean_infos``: each agent's info holds only its
    non-zero ``step_stats`` and ``TimeLimit.truncated`` when true (an empty dict most steps);
    for training, since SuperSuit deep-copies every info of every step (0.6-0.9 ms a step
    for 56 full infos, measured here). Default False.
    ``external_values``: the target values come from outside (the stage-2 high-level policy,
    ``cmdp_pymunk.highlevel``) instead of ``evaluator``. After ``reset`` and every ``step``,
    ``pending_values`` lists the crews whose scope must be valued now (section 3.6: a new
    scope, or ``reevaluate_after_steps`` steps without reaching); give each one its values with
    ``set_target_values(agent, values)`` before the next ``step``, then ``observe()`` gives the
    reaching observations with the new values (Eq. 3). The idle jump stops at such a step.
    With the same values the schedule is the one the evaluator would have made.
    ``stall_s``: the stall guard. An episode in which no task moves on (no progress, no task
    ending) for this many simulated seconds is truncated: every agent's info gets
    ``"stalled": True`` and ``"TimeLimit.truncated": True``, and ``env.stalled`` holds
    ``{"after_s", "time_s"}``. ``None`` (the default) turns it off; then only ``max_time_s``
    ends an episode that never finishes.

Global state
    ``state()`` and ``state_space``: one fixed-size float32 vector (578 floats in the built-in
    case) of every crew's position, heading, status, load and target, every task's pool and
    progress, storage stocks, the crane and its queue, and the time, for a centralized critic;
    the layout is documented in ``cmdp_pymunk.global_state`` (``state_layout(case)``).

One step, in the paper's order (section 3.2)
    P_phy (move, physics), P_cons (construct), Pi_cons (the decision table), target
    evaluation, observation, rewards.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from . import construct, decide, events, move, observe, reward
from .case import Case, as_case
from .evaluate import (
    NearestFirstEvaluator,
    TargetEvaluator,
    assign_target_values,
    crews_needing_values,
)
from .global_state import global_state, state_bounds
from .state import CrewStatus, Site, activity
from .world import N_KINDS, World

# per-agent counts of one step() call, in infos[agent]["step_stats"] (training metrics)
STEP_STATS = ("reaches", "timeouts", "reaching", "collisions", "congestion")


class CMDPEnv(ParallelEnv):
    metadata = {"name": "cmdp_pymunk_v1", "render_modes": ["rgb_array"], "render_fps": 10,
                "is_parallelizable": True}

    def __init__(self, case: Case | str | Path | None = None, stage: int = 2,
                 seed: int | None = None, evaluator: TargetEvaluator | None = None,
                 render_mode: str | None = None, jump_idle: bool = True,
                 max_time_s: float | None = None, position_log_every_s: float | None = None,
                 park_idle: bool = False, lean_infos: bool = False,
                 external_values: bool = False,
                 stall_s: float | None = None):
        if stage not in (1, 2):
            raise ValueError(f"stage must be 1 (section 4.2's simplified CMDP) or 2 (the full "
                             f"CMDP), not {stage!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f'render_mode must be None or "rgb_array", not {render_mode!r}')
        self.case = as_case(case)
        self.stage = stage
        self.render_mode = render_mode
        self.jump_idle = jump_idle
        self.position_log_every_s = position_log_every_s
        self.park_idle = park_idle
        self.lean_infos = lean_infos
        self.external_values = external_values
        self._pending: list[int] = []
        self.evaluator = evaluator if evaluator is not None else NearestFirstEvaluator()
        sim = self.case.simulation
        self.max_time_s = float(max_time_s if max_time_s is not None else sim.max_time_s)
        if not math.isfinite(self.max_time_s) or self.max_time_s <= 0:
            raise ValueError(f"max_time_s must be a positive finite number of seconds, not "
                             f"{self.max_time_s!r}")
        if stall_s is not None and not (math.isfinite(stall_s) and stall_s > 0):
            raise ValueError(f"stall_s must be a positive finite number of seconds or None "
                             f"(no stall guard), not {stall_s!r}")
        self.stall_s = stall_s
        self.stalled: dict | None = None
        self.rays = observe.RayModel(sim.frontal_rays, sim.surrounding_rays,
                                     sim.field_of_view_deg, sim.sight_distance_m,
                                     sim.surrounding_distance_m, sim.target_memory,
                                     sim.reevaluate_after_steps * sim.step_s)
        self.eta = reward.eta_by_kind(self.case.reaching_reward)
        self._reach_cap = sim.reevaluate_after_steps
        self.possible_agents = [c.id for c in self.case.crews]
        self.agent_index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self._obs_low, self._obs_high = observe.observation_bounds(self.rays, self.case)
        self._observation_space = spaces.Box(self._obs_low, self._obs_high, dtype=np.float32)
        self._action_space = spaces.MultiDiscrete(move.ACTION_NVEC)
        self._idle_obs = np.zeros(self.rays.size, dtype=np.float32)
        self._state_low, self._state_high = state_bounds(self.case)
        self.state_space = spaces.Box(self._state_low, self._state_high, dtype=np.float32)
        self.rng = np.random.default_rng(seed)
        self.clock = None  # a timing.StageClock to split wall time by stage (benchmarks)
        self.site: Site | None = None
        self.world: World | None = None
        self.log = events.EventLog()

    def observation_space(self, agent: str) -> spaces.Space:
        # one object, built in __init__, for every agent and every call (PettingZoo needs it)
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_space

    # -- episode ------------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.site = Site(self.case, self.stage)
        self.world = World(self.case, self.site)
        self.log = events.EventLog()
        if self.stage == 1:  # unrestricted stockpiles (section 5.2): storages start full and
            for storage in self.site.storages:  # are never drawn down; crews still fetch
                storage.stock = storage.capacity
        for crew in self.site.crews:
            self.log.add(0.0, "crew_state", crew.id, crew.status.name.lower())
        self.activities = [""] * len(self.site.crews)
        self._obs_cache = [None] * len(self.site.crews)
        self._last_logged = [None] * len(self.site.crews)
        self._no_contacts = [0] * N_KINDS
        self._step_stats = [dict.fromkeys(STEP_STATS, 0) for _ in self.site.crews]
        self._no_rewards = [0.0] * len(self.site.crews)
        self.agents = list(self.possible_agents)
        self.positions = [tuple(b.position) for b in self.world.bodies]
        self.steps = 0
        self.stalled = None
        self._progress_mark = (0.0, self._task_progress())
        ctx = self._context()
        decide.apply_decision_table(ctx)
        self._pending = []
        self._evaluate()
        self._log_activities()
        self._log_positions()
        self._action_needed = any(self.needs_action(c) for c in self.site.crews)
        observations = self._observe()
        infos = {a: self._info(i, {}, 0.0, 0, False) for i, a in enumerate(self.agents)}
        return observations, infos

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        if self._pending:
            raise RuntimeError(f"crews {self.pending_values} wait for target values; call "
                               "set_target_values(agent, values) for each before step()")
        site = self.site
        action_list = [actions.get(a, move.STAND_STILL) for a in self.possible_agents]
        rewards = [0.0] * len(self.possible_agents)
        terms = dict.fromkeys(reward.EVALUATION_TERMS, 0.0)
        reaches_before = [c.stats.reaches for c in site.crews]
        self._step_stats = [dict.fromkeys(STEP_STATS, 0) for _ in site.crews]
        elapsed = 0
        while True:
            step_rewards, step_terms = self._one_step(action_list)
            elapsed += 1
            for i, r in enumerate(step_rewards):
                rewards[i] += r
            for k, v in step_terms.items():
                terms[k] += v
            truncated = site.time_s >= self.max_time_s - 1e-9 or self._stall_check()
            if site.done or truncated or not self.jump_idle or \
                    self._action_needed or self._pending:
                break
        terminated = site.done
        agents = self.agents
        observations = self._observe()
        eval_reward = sum(terms.values())
        rew = {a: rewards[self.agent_index[a]] for a in agents}
        terms_out = {a: terminated for a in agents}
        truncs = {a: truncated and not terminated for a in agents}
        for crew in site.crews:
            self._step_stats[crew.index]["reaches"] = crew.stats.reaches - \
                reaches_before[crew.index]
        infos = {a: self._info(self.agent_index[a], terms, eval_reward, elapsed,
                               truncated and not terminated) for a in agents}
        if terminated or truncated:
            self.agents = []
        return observations, rew, terms_out, truncs, infos

    def _one_step(self, actions) -> tuple[list[float], dict[str, float]]:
        """One second of the CMDP in the paper's order (section 3.2)."""
        site, world, sim, clock = self.site, self.world, self.case.simulation, self.clock
        if clock:
            clock.start()
        # Quiet: the plane is at rest and no crew needs a movement decision, so P_phy is void.
        quiet = world.at_rest and not self._action_needed
        moving = [c.moving for c in site.crews]
        had_target = [c.moving and bool(c.scope) for c in site.crews]
        if not quiet:
            if self.park_idle:  # a parked crew stands still whatever its action
                actions = [a if self.needs_action(c) else move.STAND_STILL
                           for a, c in zip(actions, site.crews, strict=True)]
            move.apply_reaching_actions(world, site, actions)                 # P_phy, Eq. 1
            if any(moving):
                world.step(sim.step_s, sim.physics_substeps)
                self._update_positions(moving)
        site.time_s += sim.step_s
        self.steps += 1
        if clock:
            clock.lap("physics")
        construct.advance(site, self.positions, self.log, sim.step_s)         # P_cons, Eq. 2
        ctx = self._context()
        if quiet and decide.only_execution_fires(ctx):
            # Nothing but c2 (tasks progress) would fire: the decisions, the evaluation and the
            # rewards would change nothing but the counters, so only those are kept.
            for crew in site.crews:
                self._count(crew, moving[crew.index], False, self._no_contacts)
            self._log_activities()  # the crane may have woken a crew (waiting -> tasking)
            if any(moving):
                self._log_positions()
            if clock:
                clock.lap("decisions")
            return self._no_rewards, reward.evaluation_reward_terms(
                site, self.case.evaluation_reward)
        decide.apply_decision_table(ctx)                                      # Table 1
        self._evaluate()                                                      # Eq. 4 or Eq. 9
        self._log_activities()
        if any(moving):
            self._log_positions()
        if clock:
            clock.lap("decisions")
        rewards = []
        weights = self.case.reaching_reward
        for crew in site.crews:                                               # Eqs. 6-7
            contacts = world.take_contacts(crew.index)
            rewards.append(reward.reaching_reward(
                contacts, self.eta, ctx.reached_value.get(crew.index), had_target[crew.index],
                weights) if moving[crew.index] else 0.0)
            self._count(crew, moving[crew.index], had_target[crew.index], contacts)
        terms = reward.evaluation_reward_terms(site, self.case.evaluation_reward)
        self._action_needed = any(self.needs_action(c) for c in site.crews)
        if clock:
            clock.lap("rewards")
        return rewards, terms

    def _evaluate(self) -> None:
        """Target evaluation (section 3.6): by the injected evaluator, or left to the caller."""
        if self.external_values:
            self._pending = [c.index for c in crews_needing_values(self.site)]
        else:
            assign_target_values(self.site, self.evaluator, self.positions)

    @property
    def pending_values(self) -> list[str]:
        """Agents whose target scope waits for values (``external_values`` only)."""
        return [self.possible_agents[i] for i in self._pending]

    def set_target_values(self, agent: str, values: dict[int, float]) -> None:
        """V_Tar for the agent's target scope, from outside (the stage-2 policy through Eq. 4).

        ``values`` maps every target of the crew's scope (target indices, ``crew.scope``'s
        keys) to its value; Eq. 3 puts them into the crew's rays.
        """
        i = self.agent_index[agent]
        crew = self.site.crews[i]
        if values.keys() != crew.scope.keys():
            raise ValueError(f"{agent}: values for targets {sorted(values)}, but its scope is "
                             f"{sorted(crew.scope)}; fix: give one value per target in scope")
        crew.values = dict(values)
        if i in self._pending:
            self._pending.remove(i)

    def observe(self) -> dict[str, np.ndarray]:
        """The reaching observations now (after ``set_target_values``, with the new values)."""
        return self._observe()

    def _task_progress(self) -> tuple[int, float]:
        """What the stall guard watches: tasks ended and the progress of those on."""
        site = self.site
        return site.tasks_ended, sum(site.tasks[t].progress for t in site.active_areas)

    def _stall_check(self) -> bool:
        """True once no task has moved on for ``stall_s``; records ``self.stalled``."""
        if self.stall_s is None or self.site.done:
            return False
        now = self.site.time_s
        progress = self._task_progress()
        if progress != self._progress_mark[1]:
            self._progress_mark = (now, progress)
            return False
        if now - self._progress_mark[0] < self.stall_s - 1e-9:
            return False
        self.stalled = {"after_s": now - self._progress_mark[0], "time_s": now}
        return True

    def _update_positions(self, moving) -> None:
        for i, body in enumerate(self.world.bodies):
            if moving[i]:
                x, y = body.position
                px, py = self.positions[i]
                self.site.crews[i].stats.distance_m += math.hypot(x - px, y - py)
                self.positions[i] = (x, y)

    def needs_action(self, crew) -> bool:
        """Whether the crew's reaching action is used this step (section 3.6.2)."""
        if not crew.moving:
            return False
        if self.park_idle and not crew.scope and crew.status == CrewStatus.REACHING:
            return self.site.in_congestion_area(*self.positions[crew.index])
        return True

    def _log_activities(self) -> None:
        """An ``activity`` event whenever a crew's Gantt category (Fig. 9) changes."""
        for crew in self.site.crews:
            now = activity(crew)
            if now != self.activities[crew.index]:
                self.activities[crew.index] = now
                self.log.add(self.site.time_s, "activity", crew.id, now)

    def _log_positions(self) -> None:
        """``position`` events (subject "x,y,heading_deg") of crews that moved, for trajectories.

        Every ``position_log_every_s`` (in whole steps); a crew standing still logs nothing.
        """
        every = self.position_log_every_s
        if every is None or self.steps % max(1, round(every / self.case.simulation.step_s)):
            return
        for crew in self.site.crews:
            if crew.moving:
                body = self.world.bodies[crew.index]
                x, y = body.position
                last = self._last_logged[crew.index]
                if last is not None and abs(x - last[0]) + abs(y - last[1]) < 0.05:
                    continue
                self._last_logged[crew.index] = (x, y)
                self.log.add(self.site.time_s, "position", crew.id,
                             f"{x:.2f},{y:.2f},{math.degrees(body.angle) % 360:.0f}")

    def _count(self, crew, was_moving: bool, had_target: bool, contacts) -> None:
        """Per-crew counters; ``step_stats`` gathers this call's share for training metrics."""
        stats, step = crew.stats, self._step_stats[crew.index]
        if was_moving:
            if had_target:
                stats.reaching_steps += 1
                step["reaching"] += 1
                if crew.moving and crew.scope:  # still after it: one more step without a reach
                    crew.steps_since_reach += 1
                    if crew.steps_since_reach % self._reach_cap == 0:
                        stats.reach_timeouts += 1  # over the step cap without reaching
                        step["timeouts"] += 1
            else:
                crew.steps_since_reach = 0  # holding no target: no attempt under way
                if crew.status == CrewStatus.REACHING and crew.idle_cause:
                    stats.idle_steps[crew.idle_cause] += 1
            collisions = contacts[1] + contacts[2] + contacts[3]
            entries = contacts[4] + contacts[5]
            stats.collisions += collisions
            stats.congestion_entries += entries
            step["collisions"] += collisions
            step["congestion"] += entries
        elif crew.status == CrewStatus.WAITING:
            stats.crane_wait_steps += 1

    def _context(self) -> decide.Context:
        return decide.Context(self.site, self.world, self.positions, self.rng, self.log)

    def _observe(self) -> dict[str, np.ndarray]:
        """Rays are cast only for crews that need a movement decision."""
        if self.clock:
            self.clock.start()
        out = {}
        version = self.world.motion_version
        for agent in self.agents:
            i = self.agent_index[agent]
            crew = self.site.crews[i]
            if not self.needs_action(crew):
                out[agent] = self._idle_obs.copy()
                continue
            # Nothing moved and its scope and values are the same objects: the same rays.
            cached = self._obs_cache[i]
            if cached is None or cached[0] != version or cached[1] is not crew.scope \
                    or cached[2] is not crew.values:
                cached = (version, crew.scope, crew.values,
                          observe.observe_crew(self.world, self.rays, crew, self.site.time_s))
                self._obs_cache[i] = cached
            obs = out[agent] = cached[3].copy()
            if self.rays.memory:  # the age moves on even when nothing else does
                x, y = self.positions[i]
                obs[-observe.MEMORY_FEATURES:] = observe.remembered_target(
                    self.rays, crew, x, y, self.world.bodies[i].angle, self.site.time_s)
            np.clip(obs, self._obs_low, self._obs_high, out=obs)  # the space's promise
        if self.clock:
            self.clock.lap("rays")
        return out

    def _info(self, i: int, terms: dict, eval_reward: float, elapsed: int,
              time_limit: bool) -> dict:
        if self.lean_infos:
            info = {}
            stats = {k: v for k, v in self._step_stats[i].items() if v}
            if stats:
                info["step_stats"] = stats
            if time_limit:
                info["TimeLimit.truncated"] = True
                if self.stalled:
                    info["stalled"] = True
            return info
        crew = self.site.crews[i]
        info = {"status": crew.status.name.lower(), "time_s": self.site.time_s,
                "elapsed_s": elapsed, "needs_action": self.needs_action(crew),
                "evaluation_reward": eval_reward, "evaluation_terms": dict(terms),
                "step_stats": self._step_stats[i]}
        # Only when true: SuperSuit merges the next episode's reset infos over the last step's,
        # and a False there would hide the time-out from SB3 (no bootstrapping).
        if time_limit:
            info["TimeLimit.truncated"] = True
            if self.stalled:
                info["stalled"] = True
        return info

    # -- for the high level, the scripted policies and the media ------------------------------

    def evaluation_observation(self, agent: str) -> np.ndarray:
        """O^e of the crew (section 3.6.1), for the stage-2 target-evaluation policy."""
        i = self.agent_index[agent]
        body = self.world.bodies[i]
        return observe.evaluation_observation(self.site, self.site.crews[i], self.positions[i],
                                              body.angle)

    def state(self) -> np.ndarray:
        """The global state: a fixed-size float32 vector in ``state_space`` with every crew's
        position, heading, status, load and target, every task's pool and progress, the
        storages' stocks, the crane and its queue, and the time (layout:
        ``cmdp_pymunk.global_state``), for centralized critics."""
        if self.site is None:
            raise RuntimeError("state() before the first reset(); call reset() first")
        headings = [body.angle for body in self.world.bodies]
        out = global_state(self.site, self.positions, headings, self.max_time_s)
        return np.clip(out, self._state_low, self._state_high, out=out)

    @property
    def makespan_s(self) -> float | None:
        """Simulated seconds until the last task ended, once every task has."""
        return self.site.time_s if self.site is not None and self.site.done else None

    def render(self):
        if self.render_mode is None:
            return None
        from media.render import draw_frame  # the simulation core never imports pygame

        return draw_frame(self)

    def close(self) -> None:
        pass
