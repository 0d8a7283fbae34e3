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
    ``reset()`` keeps it). ``evaluator``: fills V_Tar; an ``evaluate.TargetEvaluator`` (GA
    priorities, the stage-2 model, the lookahead, ...) or a name of ``evaluate.EVALUATORS``;
    default ``"priority"``, the priority heuristic (Eq. 9), as for ``pettingzoo.make``.
    ``None``: values come from outside, as for the engine (``env.engine.pending`` and
    ``set_target_values`` before each step).
    ``render_mode``: ``None`` or ``"rgb_array"``. ``jump_idle``: when no crew needs a
    movement decision (all tasking, fetching, waiting or gone), one ``step`` call runs on to
    the next second at which one does; ``infos[agent]["elapsed_s"]`` says how far.
    ``max_time_s`` overrides the case's time limit.
    ``park_idle``: a crew without a target that stands outside every task area and storage is
    parked: it stands still, needs no movement decision and does not hold up the idle jump (the
    paper lets such crews manoeuvre; a scripted low level that only parks them runs faster this
    way). Default False.
    ``position_log_every_s``: log moving crews' positions to the event log this often (for
    trajectory charts); ``None`` logs none. ``lean_infos``: each agent's info holds only its
    non-zero ``step_stats`` and ``TimeLimit.truncated`` when true (an empty dict most steps);
    for training, since SuperSuit deep-copies every info of every step (0.6-0.9 ms a step
    for 56 full infos, measured here). Default False.
    ``stall_s``: the stall guard. An episode in which no task moves on (no progress, no task
    ending) for this many simulated seconds is truncated: every agent's info gets
    ``"stalled": True`` and ``"TimeLimit.truncated": True``, and ``env.stalled`` holds
    ``{"after_s", "time_s"}``. ``None`` (the default) turns it off; then only ``max_time_s``
    ends an episode that never finishes.
    ``blind``: no rays are cast; every observation is all zeros. For a low level that reads
    the state instead of the rays (the scripted navigator): the ray casts are a fifth of such
    a floor's time. The schedule is the same (rays change nothing but observations). Default
    False. ``renderer``: draws ``render()``'s frame from the engine and the rays,
    ``renderer(engine, rays)`` (default ``media.render.draw_frame``).

Low levels
    A ``policy.LowLevel`` answers by crew index on the engine; ``agent_actions(low_level,
    observations)`` is the one place its answer becomes a dict by agent name.

Global state
    ``state()`` and ``state_space``: one fixed-size float32 vector (578 floats in the built-in
    case) of every crew's position, heading, status, load and target, every task's pool and
    progress, storage stocks, the crane and its queue, and the time, for a centralized critic;
    the layout is documented in ``cmdp_pymunk.adapters.global_state`` (``state_layout(case)``).

One step, in the paper's order (section 3.2)
    The actions move the crews (P_phy), construction advances (P_cons), and the next second
    is decided (Pi_cons), valued and rewarded: ``engine.Engine.step``; the crews then observe
    it (Eq. 3) for their next action. ``reset`` decides, values and observes the first second.

The dynamics are ``engine.Engine``'s; this module is the PettingZoo adapter over it (agents'
names, spaces, dicts of arrays, infos).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from .. import ENV_NAME, move, observe
from ..cases.load import Case, as_case
from ..engine import Engine
from ..evaluate import DEFAULT_EVALUATOR, TargetEvaluator
from ..policy import LowLevel
from .global_state import global_state, state_bounds

# The renderer used when none is injected: named, not imported (the core imports no pygame).
DEFAULT_RENDERER = "media.render:draw_frame"


class CMDPEnv(ParallelEnv):
    metadata = {"name": ENV_NAME, "render_modes": ["rgb_array"], "render_fps": 10,
                "is_parallelizable": True}

    def __init__(self, case: Case | str | Path | None = None, stage: int = 2,
                 seed: int | None = None,
                 evaluator: TargetEvaluator | str | None = DEFAULT_EVALUATOR,
                 render_mode: str | None = None, jump_idle: bool = True,
                 max_time_s: float | None = None, position_log_every_s: float | None = None,
                 park_idle: bool = False, lean_infos: bool = False,
                 stall_s: float | None = None,
                 renderer: Callable[..., np.ndarray] | None = None,
                 blind: bool = False):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f'render_mode must be None or "rgb_array", not {render_mode!r}')
        case = as_case(case)
        self.engine = Engine(case, stage, evaluator, seed, max_time_s, park_idle, stall_s,
                             position_log_every_s)
        self.render_mode = render_mode
        self.renderer = renderer
        self.jump_idle = jump_idle
        self.lean_infos = lean_infos
        self.blind = blind
        self._reaching = observe.ReachingObservations(case)
        self.rays = self._reaching.rays
        self.possible_agents = [c.id for c in case.crews]
        self.agent_index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self._observation_space = spaces.Box(self._reaching.low, self._reaching.high,
                                             dtype=np.float32)
        self._action_space = spaces.MultiDiscrete(move.ACTION_NVEC)
        self._state_low, self._state_high = state_bounds(case)
        self.state_space = spaces.Box(self._state_low, self._state_high, dtype=np.float32)

    def observation_space(self, agent: str) -> spaces.Space:
        # one object, built in __init__, for every agent and every call (PettingZoo needs it)
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_space

    # -- the episode --------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        self.agents = list(self.possible_agents)
        self._reaching.reset()
        self.engine.reset(seed)                           # Pi_cons and V_Tar for t = 0
        observations = self._observe()                    # Eq. 3
        infos = {a: self._info(i, {}, 0.0, 0, False) for i, a in enumerate(self.agents)}
        return observations, infos

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        engine, agents = self.engine, self.agents
        # move, construct, decide, evaluate, reward; on through seconds where nothing is asked
        run = engine.advance([actions.get(a, move.STAND_STILL) for a in self.possible_agents],
                             until=engine.decision_due if self.jump_idle else None)
        observations = self._observe()                    # Eq. 3, for the next actions
        done, cut = run.terminated, run.truncated and not run.terminated
        eval_reward = sum(run.terms.values())
        rewards = {a: run.rewards[self.agent_index[a]] for a in agents}
        infos = {a: self._info(self.agent_index[a], run.terms, eval_reward, run.elapsed, cut)
                 for a in agents}
        terminations, truncations = dict.fromkeys(agents, done), dict.fromkeys(agents, cut)
        if run.terminated or run.truncated:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    # -- observations and infos ---------------------------------------------------------------

    def _observe(self) -> dict[str, np.ndarray]:
        """Rays are cast only for crews that need a movement decision
        (``observe.ReachingObservations``)."""
        if self.blind:
            return {agent: self._reaching.idle.copy() for agent in self.agents}
        return {agent: self._reaching.crew(self.engine, self.agent_index[agent])
                for agent in self.agents}

    def agent_actions(self, low_level: LowLevel, observations: dict | None) -> dict:
        """A low level's actions (by crew index, on the engine) as a dict by agent name, from
        the observations by agent name (passed on only if it ``reads_rays``)."""
        obs = [observations[a] for a in self.possible_agents] \
            if low_level.reads_rays and observations is not None else None
        return dict(zip(self.possible_agents, low_level.actions(self.engine, obs), strict=True))

    def _info(self, i: int, terms: dict, eval_reward: float, elapsed: int,
              time_limit: bool) -> dict:
        window = self.engine.metrics.window[i]
        if self.lean_infos:
            info = {}
            stats = {k: v for k, v in window.items() if v}
            if stats:
                info["step_stats"] = stats
            if time_limit:
                info["TimeLimit.truncated"] = True
                if self.stalled:
                    info["stalled"] = True
            return info
        site = self.engine.site
        crew = site.crews[i]
        info = {"status": crew.status.name.lower(), "time_s": site.time_s,
                "elapsed_s": elapsed, "needs_action": self.engine.needs_action(crew),
                "evaluation_reward": eval_reward, "evaluation_terms": dict(terms),
                "step_stats": window}
        # Only when true: SuperSuit merges the next episode's reset infos over the last step's,
        # and a False there would hide the time-out from SB3 (no bootstrapping).
        if time_limit:
            info["TimeLimit.truncated"] = True
            if self.stalled:
                info["stalled"] = True
        return info

    # -- for centralized critics and the media -------------------------------------------------

    def state(self) -> np.ndarray:
        """The global state: a fixed-size float32 vector in ``state_space`` with every crew's
        position, heading, status, load and target, every task's pool and progress, the
        storages' stocks, the crane and its queue, and the time (layout:
        ``cmdp_pymunk.adapters.global_state``), for centralized critics."""
        engine = self.engine
        if engine.site is None:
            raise RuntimeError("state() before the first reset(); call reset() first")
        out = global_state(engine.site, engine.positions, engine.headings(), engine.max_time_s)
        return np.clip(out, self._state_low, self._state_high, out=out)

    def render(self):
        """A frame (H, W, 3) by the injected ``renderer``, by default ``DEFAULT_RENDERER``."""
        if self.render_mode is None:
            return None
        if self.renderer is None:
            module, name = DEFAULT_RENDERER.split(":")
            self.renderer = getattr(importlib.import_module(module), name)
        return self.renderer(self.engine, self.rays)

    def close(self) -> None:
        pass

    # -- what an episode's caller reads: the case, the event log and how the episode ended ----
    # The floor's state (site, poses, the plane) is the engine's: ``env.engine``.

    case = property(lambda self: self.engine.case)
    log = property(lambda self: self.engine.log)
    stalled = property(lambda self: self.engine.stalled)
    makespan_s = property(lambda self: self.engine.makespan_s,
                          doc="Simulated seconds until the last task ended, once every task has.")

    # settable: training (``MixedStageEnv``) switches stage and time limit between episodes
    @property
    def evaluator(self) -> TargetEvaluator | None:
        """Values the targets (section 3.6); None: values from outside."""
        return self.engine.evaluator

    @evaluator.setter
    def evaluator(self, value: TargetEvaluator | str | None) -> None:
        self.engine.evaluator = value

    @property
    def stage(self) -> int:
        return self.engine.stage

    @stage.setter
    def stage(self, value: int) -> None:
        self.engine.stage = value

    @property
    def max_time_s(self) -> float:
        return self.engine.max_time_s

    @max_time_s.setter
    def max_time_s(self, value: float) -> None:
        self.engine.max_time_s = value

    @property
    def stall_s(self) -> float | None:
        return self.engine.stall_s

    @stall_s.setter
    def stall_s(self, value: float | None) -> None:
        self.engine.stall_s = value
