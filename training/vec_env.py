"""Env copies in fewer worker processes than copies: ``num_cpus`` means processes.

SB3's ``SubprocVecEnv`` starts one process per env copy; on a machine with fewer cores than
copies they then fight over the cores (shared/PITFALLS.md). ``ProcessGroupsVecEnv`` splits the
copies, in order, into one vector env per worker process (``vectorize``: a ``DummyVecEnv`` by
default, as SuperSuit's ``concat_vec_envs_v1`` does for stage 1), so the copies, their seeds
(copy k: seed + k), their resets and their infos are those of one such vector of all of them.

``FloorsVecEnv``: k stage-2 floors (``cmdp_pymunk.adapters.decision_loop.DecisionLoop``) stepped in
one process behind one SB3 vector env: actions in, arrays out, no Gymnasium env, dict or info on
the way
(an info only where an episode ended). Stage 2 trains on ``num_cpus`` processes, each holding
its share of the ``n_envs`` floors in one of these.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper


class FloorsVecEnv(VecEnv):
    """``len(floor_fns)`` stage-2 floors in this process behind one SB3 vector env (see the
    module doc). DecisionLoop k's episodes are those of ``decision_loop.TargetEvaluationEnv`` over
    it in a ``DummyVecEnv``: the same seeds (the first given by ``seed``, the next drawn from a
    generator made from it), observations, rewards (float32), ends and end infos
    (``terminal_observation`` all zeros; ``TimeLimit.truncated`` only when true)."""

    def __init__(self, floor_fns: list[Callable[[], Any]]):
        self.floors = [make() for make in floor_fns]
        first = self.floors[0]
        self.actor_size = first.actor_size
        # Eq. 4's desired position, unless the floor says otherwise (training.candidate_loop)
        action_space = getattr(first, "action_space", spaces.Box(-1.0, 1.0, (2,), np.float32))
        super().__init__(len(self.floors), spaces.Box(first.low, first.high, dtype=np.float32),
                         action_space)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._obs = np.zeros((self.num_envs, len(first.low)), np.float32)
        self._actions = None

    def _reset_floor(self, k: int, seed: int | None) -> None:
        if seed is not None or self._rngs[k] is None:
            self._rngs[k], _ = seeding.np_random(seed)  # as gymnasium's Env.reset(seed)
        if seed is None:
            seed = int(self._rngs[k].integers(2**31))
        self.floors[k].reset(seed)
        self.floors[k].observe(self._obs[k])

    def reset(self) -> np.ndarray:
        for k in range(self.num_envs):
            self._reset_floor(k, self._seeds[k])
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        rewards = np.zeros(self.num_envs, np.float32)
        dones = np.zeros(self.num_envs, bool)
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        for k, floor in enumerate(self.floors):
            out = floor.decide(self._actions[k])
            rewards[k] = out.reward
            if out.terminated or out.truncated:
                dones[k] = True
                infos[k] = floor.end_info()
                infos[k]["terminal_observation"] = np.zeros(self._obs.shape[1], np.float32)
                if out.truncated:
                    infos[k]["TimeLimit.truncated"] = True
                self._reset_floor(k, None)
            else:
                floor.observe(self._obs[k])
        return self._obs.copy(), rewards, dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices=None) -> list:
        """An attribute of each floor (``render_mode``: None; there is nothing to render)."""
        if attr_name == "render_mode":
            return [None for _ in self._get_indices(indices)]
        return [getattr(self.floors[k], attr_name) for k in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for k in self._get_indices(indices):
            setattr(self.floors[k], attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        return [getattr(self.floors[k], method_name)(*method_args, **method_kwargs)
                for k in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def _worker(remote, parent_remote, make: CloudpickleWrapper) -> None:
    """Serve one vector env of this worker's copies: each request names one of its methods
    (or attributes) and the arguments; the answer is what it returns (with the copies' reset
    infos after ``reset`` and ``step``), or the exception it raised."""
    parent_remote.close()
    vectorize, env_fns = make.var
    venv = vectorize(env_fns)
    while True:
        try:
            name, args, kwargs = remote.recv()
        except (EOFError, KeyboardInterrupt):
            break
        if name == "close":
            venv.close()
            remote.close()
            break
        try:
            value = getattr(venv, name)
            value = value(*args, **kwargs) if callable(value) else value
        except Exception as err:  # raised again in the main process
            remote.send((False, err))
            continue
        remote.send((True, (value, venv.reset_infos) if name in ("reset", "step") else value))


def _answer(remote):
    ok, value = remote.recv()
    if not ok:
        raise value
    return value


class ProcessGroupsVecEnv(VecEnv):
    """``len(env_fns)`` copies stepped by ``processes`` worker processes (see the module
    doc); ``processes`` must be 1 to ``len(env_fns)``; each worker holds
    ``vectorize(its env_fns)`` (default ``DummyVecEnv``). Box observations only."""

    def __init__(self, env_fns: list[Callable[[], Any]], processes: int,
                 start_method: str = "fork",
                 vectorize: Callable[[list], VecEnv] = DummyVecEnv):
        n = len(env_fns)
        if not 1 <= processes <= n:
            raise ValueError(f"processes = {processes} must be 1 to the number of env copies "
                             f"({n})")
        sizes = [n // processes + (k < n % processes) for k in range(processes)]
        self.starts = [0, *np.cumsum(sizes).tolist()]
        ctx = mp.get_context(start_method)
        self.remotes, self.processes = [], []
        for k in range(processes):
            remote, work_remote = ctx.Pipe()
            fns = CloudpickleWrapper((vectorize, env_fns[self.starts[k]:self.starts[k + 1]]))
            process = ctx.Process(target=_worker, args=(work_remote, remote, fns), daemon=True)
            process.start()
            work_remote.close()
            self.remotes.append(remote)
            self.processes.append(process)
        self.closed = False
        self.waiting = False
        spaces = self._ask_first("observation_space"), self._ask_first("action_space")
        super().__init__(n, *spaces)

    # -- requests to the workers, by the copies they concern

    def _ask_first(self, name: str):
        self.remotes[0].send((name, (), {}))
        return _answer(self.remotes[0])

    def _ask_all(self, name: str, per_worker: list[tuple] | None = None, **kwargs) -> list:
        """Every worker's answer to ``name`` (``per_worker``: its own arguments)."""
        for k, remote in enumerate(self.remotes):
            remote.send((name, per_worker[k] if per_worker else (), kwargs))
        return [_answer(remote) for remote in self.remotes]

    def _ask_copies(self, name: str, indices, *args, **kwargs) -> list:
        """``name(*args, indices=local ones, **kwargs)`` on the workers holding ``indices``;
        their answers flattened in the order of the copies."""
        wanted = list(self._get_indices(indices))
        asked = []
        for k, remote in enumerate(self.remotes):
            local = [i - self.starts[k] for i in wanted
                     if self.starts[k] <= i < self.starts[k + 1]]
            if local:
                remote.send((name, args, {**kwargs, "indices": local}))
                asked.append((k, local))
        by_copy = {}
        for k, local in asked:
            answer = _answer(self.remotes[k])
            if answer is None:  # set_attr
                answer = [None] * len(local)
            by_copy.update(zip([self.starts[k] + i for i in local], answer, strict=True))
        return [by_copy[i] for i in wanted]

    # -- VecEnv

    def seed(self, seed: int | None = None) -> list[int | None]:
        """Copy k gets ``seed + k`` at the next reset."""
        firsts = [(None if seed is None else seed + start,) for start in self.starts[:-1]]
        return [s for seeds in self._ask_all("seed", firsts) for s in seeds]

    def set_options(self, options: list[dict] | dict | None = None) -> None:
        if isinstance(options, list):
            per_worker = [(options[self.starts[k]:self.starts[k + 1]],)
                          for k in range(len(self.remotes))]
        else:
            per_worker = [(options,)] * len(self.remotes)
        self._ask_all("set_options", per_worker)

    def reset(self):
        answers = self._ask_all("reset")
        self.reset_infos = [info for _, infos in answers for info in infos]
        return np.concatenate([obs for obs, _ in answers])

    def step_async(self, actions: np.ndarray) -> None:
        for k, remote in enumerate(self.remotes):
            remote.send(("step", (actions[self.starts[k]:self.starts[k + 1]],), {}))
        self.waiting = True

    def step_wait(self):
        answers = [_answer(remote) for remote in self.remotes]
        self.waiting = False
        self.reset_infos = [info for _, infos in answers for info in infos]
        obs, rewards, dones, infos = zip(*(result for result, _ in answers), strict=True)
        return (np.concatenate(obs), np.concatenate(rewards), np.concatenate(dones),
                [info for part in infos for info in part])

    def close(self) -> None:
        if self.closed:
            return
        if self.waiting:
            for remote in self.remotes:
                _answer(remote)
        for remote in self.remotes:
            remote.send(("close", (), {}))
        for process in self.processes:
            process.join()
        for remote in self.remotes:
            remote.close()
        self.closed = True

    def get_attr(self, attr_name: str, indices=None) -> list:
        return self._ask_copies("get_attr", indices, attr_name)

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        self._ask_copies("set_attr", indices, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        return self._ask_copies("env_method", indices, method_name, *method_args,
                                **method_kwargs)

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return self._ask_copies("env_is_wrapped", indices, wrapper_class)
