"""The stage-2 high-level env: one step is one target evaluation (sections 3.6, 3.6.1).

A Gymnasium env over ``CMDPEnv`` with ``external_values=True``: the simulation runs on with an
injected low level (the scripted navigator or the stage-1 reaching policy) until a crew needs
its target scope valued, and the policy answers for that crew.

Observation
    O^e of section 3.6.1 from the deciding crew's view (``observe.evaluation_observation``):
    the crew's own 5 floats, then 12 floats for every potential target of the episode, so the
    size is fixed (``Box(5 + 12 * n_targets)``, bounded).

Action
    ``Box(-1, 1, (2,))``: the desired position (x/x_max, y/y_max); every target in the crew's
    scope gets V_Tar by Eq. 4 (``evaluate.DesiredPositionEvaluator``), which the low level
    reads through Eq. 3.

When a decision is asked for (section 3.6)
    When a crew acquires a target scope, and after ``reevaluate_after_steps`` steps without
    reaching a target. A scope of one target leaves nothing to choose: it is valued 1 without
    asking the policy, and no transition enters the policy's buffer for it.

The formulation: one shared policy makes the team's decisions in sequence
    Several crews decide at different times. The policy is shared by every crew (the crew is
    told apart by O^e's own floats and the target-scope flags), and its decisions form one
    sequence in simulated time (a semi-Markov decision process over the team). The reward of
    a decision is the team's R_e (Eq. 5) summed over the simulated seconds from that decision
    to the next decision of any crew (``decision_reward``); two decisions at the same second
    leave the first one 0. PPO discounts by decision, not by second. Only real decisions enter
    the buffer: the simulation between two decisions is hidden inside ``step``.

Episode end
    ``terminated`` when every task has ended. ``truncated`` at the time limit, or when no task
    moves on for ``stall_s`` simulated seconds (``info["stalled"]``): a stalled floor teaches
    nothing.

Info
    ``time_s``, ``elapsed_s`` (simulated seconds this step ran), ``agent`` (the crew that
    decides next), ``evaluation_terms`` (R_e's terms summed over this step), and at the end
    ``makespan_s`` (None unless every task ended) and ``stalled``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from . import observe, reward
from .env import CMDPEnv
from .evaluate import DesiredPositionEvaluator
from .policy import LowLevel


def decision_reward(step_terms: list[Mapping[str, float]]) -> float:
    """The reward credited to one decision: the team's R_e (Eq. 5) summed over the simulated
    steps from that decision to the next one, ``step_terms`` holding each step's terms."""
    return float(sum(sum(terms.values()) for terms in step_terms))


class TargetEvaluationEnv(gym.Env):
    """One step = one target evaluation by the shared high-level policy (see the module doc).

    ``make_low_level(env)`` builds the low level over the inner ``CMDPEnv`` (e.g.
    ``agents.navigator.Navigator``, a ``policy.LowLevel``); its ``reset(seed)`` is called every
    episode.
    ``stall_s``: truncate an episode in which no task moves on for this long.
    Other keyword arguments go to ``CMDPEnv``.
    """

    metadata = {"render_modes": []}

    def __init__(self, make_low_level: Callable[[CMDPEnv], LowLevel], case=None,
                 stall_s: float = 3600.0, **env_kwargs):
        self.env = CMDPEnv(case=case, stage=2, external_values=True, **env_kwargs)
        self.low_level = make_low_level(self.env)
        self.stall_s = float(stall_s)
        self.evaluator = DesiredPositionEvaluator()
        self.env.reset(seed=0)  # to size O^e
        size = observe.evaluation_size(self.env.site)
        low, high = observe.evaluation_bounds(self.env.site)
        self.observation_space = spaces.Box(low, high, (size,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._queue: list[str] = []
        self._agent: str | None = None
        self._observations: dict = {}

    # -- the decisions ------------------------------------------------------------------------

    @property
    def deciding_agent(self) -> str | None:
        """The crew whose scope the next action values."""
        return self._agent

    def _decision_observation(self) -> np.ndarray:
        env, i = self.env, self.env.agent_index[self._agent]
        obs = observe.evaluation_observation(env.site, env.site.crews[i], env.positions[i],
                                             env.world.bodies[i].angle)
        return np.clip(obs, self.observation_space.low, self.observation_space.high)

    def _next_decision(self) -> bool:
        """Take the next crew that must choose among several targets; value lone targets."""
        env = self.env
        while True:
            if not self._queue:
                self._queue = list(env.pending_values)
                if not self._queue:
                    return False
            agent = self._queue.pop(0)
            scope = env.site.crews[env.agent_index[agent]].scope
            if len(scope) > 1:
                self._agent = agent
                return True
            env.set_target_values(agent, {t: 1.0 for t in scope})

    def _run_until_decision(self) -> tuple[list[dict], bool, bool]:
        """Advance the simulation with the low level until a crew must decide or it ends."""
        env, site = self.env, self.env.site
        step_terms: list[dict] = []
        stalled = False
        while True:
            if self._next_decision():
                return step_terms, False, False
            self._observations = env.observe()
            _, _, terms, truncs, infos = env.step(self.low_level.actions(env,
                                                                         self._observations))
            info = next(iter(infos.values()))
            step_terms.append(info["evaluation_terms"])
            moved = sum(t.progress for t in site.tasks) + site.tasks_ended
            if moved != self._progress[1]:
                self._progress = (site.time_s, moved)
            elif site.time_s - self._progress[0] >= self.stall_s:
                stalled = True
            if not env.agents or stalled:
                self._stalled = stalled
                return step_terms, site.done, not site.done

    # -- gymnasium ----------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is None:  # one generator for the whole run, drawn from gymnasium's
            seed = int(self.np_random.integers(2**31))
        self._observations, _ = self.env.reset(seed=seed)
        self.low_level.reset(seed)
        self._queue, self._agent, self._stalled = [], None, False
        self._progress = (0.0, -1.0)
        self._start_s = 0.0
        step_terms, terminated, truncated = self._run_until_decision()
        if terminated or truncated:  # a floor with nothing to choose: nothing to learn
            raise RuntimeError("the episode ended before any crew had a choice to make")
        return self._decision_observation(), self._info(step_terms)

    def step(self, action):
        if self._agent is None:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        env, agent = self.env, self._agent
        i = env.agent_index[agent]
        crew = env.site.crews[i]
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        self.evaluator.desired[i] = (float(a[0]), float(a[1]))
        env.set_target_values(agent, self.evaluator.target_values(crew, env.site,
                                                                  env.positions[i]))
        self._agent = None
        self._start_s = env.site.time_s
        step_terms, terminated, truncated = self._run_until_decision()
        info = self._info(step_terms)
        if terminated or truncated:
            info["makespan_s"] = env.makespan_s
            info["stalled"] = self._stalled
            info["tasks_ended"] = env.site.tasks_ended
            obs = np.zeros(self.observation_space.shape, np.float32)
        else:
            obs = self._decision_observation()
        return obs, decision_reward(step_terms), terminated, truncated, info

    def _info(self, step_terms: list[dict]) -> dict:
        totals = dict.fromkeys(reward.EVALUATION_TERMS, 0.0)
        for terms in step_terms:
            for k, v in terms.items():
                totals[k] += v
        return {"time_s": self.env.site.time_s, "elapsed_s": self.env.site.time_s - self._start_s,
                "agent": self._agent, "evaluation_terms": totals}
