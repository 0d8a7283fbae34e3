"""Env copies in fewer worker processes than copies: ``num_cpus`` means processes.

SB3's ``SubprocVecEnv`` starts one process per env copy; on a machine with fewer cores than
copies they then fight over the cores (shared/PITFALLS.md). ``ProcessGroupsVecEnv`` splits the
copies, in order, into one ``DummyVecEnv`` per worker process (as SuperSuit's
``concat_vec_envs_v1`` does for stage 1), so the copies, their seeds (copy k: seed + k), their
resets and their infos are those of one ``DummyVecEnv`` of all of them.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper


def _worker(remote, parent_remote, env_fns: CloudpickleWrapper) -> None:
    """Serve one ``DummyVecEnv`` of this worker's copies: each request names one of its
    methods (or attributes) and the arguments; the answer is what it returns (with the
    copies' reset infos after ``reset`` and ``step``), or the exception it raised."""
    parent_remote.close()
    venv = DummyVecEnv(env_fns.var)
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
    doc); ``processes`` must be 1 to ``len(env_fns)``. Box observations only."""

    def __init__(self, env_fns: list[Callable[[], Any]], processes: int,
                 start_method: str = "fork"):
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
            fns = CloudpickleWrapper(env_fns[self.starts[k]:self.starts[k + 1]])
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
