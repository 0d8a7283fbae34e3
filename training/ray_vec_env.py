"""Env copies on Ray actors: ``cmdp-train stage2 --ray [ADDRESS]`` (docs/ray.md).

``RayGroupsVecEnv`` is ``vec_env.ProcessGroupsVecEnv`` with its worker processes swapped for
Ray actors: the ``n_envs`` copies are split, in order, into ``actors`` groups, each held by
one actor (on any node of the cluster) as one ``vectorize(its env_fns)`` (stage 2: a
``FloorsVecEnv``), and the learner sends every request to the actors holding the copies it
concerns, as it would down a pipe. So the copies, their seeds (copy k: seed + k), their
resets, observations, rewards and infos are those of the local vector env; only where they
are stepped changes. SB3's PPO stays one learner in this process: what Ray spreads is the
stepping of the floors, not the update.

Imported only with ``--ray``: the default install needs no Ray. An actor that dies stops the
run with Ray's error (the last checkpoint is where to resume from); Ctrl-C kills the actors.
"""

from __future__ import annotations

import os
import socket
from collections import deque
from collections.abc import Callable
from typing import Any

from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper

from training.runs.ray_backend import (
    START_TIMEOUT_S,
    ClusterError,
    cannot_run_here,
    check_workers,
    connect,
    ray,
    require_ray,
)

from .vec_env import ProcessGroupsVecEnv


class _VecGroup:
    """One actor: its share of the copies as one vector env, serving the requests of
    ``vec_env._worker`` (a method or attribute of the vector env, by name)."""

    def __init__(self, make: CloudpickleWrapper):
        try:  # one torch thread per actor (shared/PITFALLS.md)
            import torch

            torch.set_num_threads(1)
        except ImportError:
            pass
        vectorize, env_fns = make.var
        self.venv = vectorize(env_fns)

    def where(self) -> dict:
        import cmdp_pymunk

        return {"host": socket.gethostname(), "pid": os.getpid(),
                "version": cmdp_pymunk.__version__}

    def call(self, name: str, args: tuple, kwargs: dict) -> tuple[bool, Any]:
        try:
            value = getattr(self.venv, name)
            value = value(*args, **kwargs) if callable(value) else value
        except Exception as err:  # raised again in the learner's process
            return False, err
        return True, (value, self.venv.reset_infos) if name in ("reset", "step") else value


class _ActorPipe:
    """An actor seen as the learner's end of a worker's pipe: ``send`` submits a request,
    ``recv`` waits for the oldest unanswered one (an actor runs its calls in the order they
    were sent, as a pipe delivers them)."""

    def __init__(self, actor):
        self.actor = actor
        self.pending: deque = deque()

    def send(self, request: tuple) -> None:
        self.pending.append(self.actor.call.remote(*request))

    def recv(self):
        return ray.get(self.pending.popleft())


class RayGroupsVecEnv(ProcessGroupsVecEnv):
    """``len(env_fns)`` copies stepped by ``actors`` Ray actors (1 CPU each, spread over the
    nodes), each holding ``vectorize(its env_fns)``; ``address``: "local" (a Ray started
    here with ``actors`` CPUs) or a cluster's address (see the module doc)."""

    def __init__(self, env_fns: list[Callable[[], Any]], actors: int, address: str = "local",
                 vectorize: Callable[[list], VecEnv] = DummyVecEnv):
        require_ray()
        n = len(env_fns)
        if not 1 <= actors <= n:
            raise ValueError(f"actors = {actors} must be 1 to the number of env copies ({n})")
        self.address = address
        self._started = connect(address, actors)
        self.actors: list = []
        try:
            cpus = int(ray.cluster_resources().get("CPU", 0))
            sizes = [n // actors + (k < n % actors) for k in range(actors)]
            self.starts = [0, *[sum(sizes[:k + 1]) for k in range(actors)]]
            group = ray.remote(_VecGroup).options(num_cpus=1, max_restarts=0,
                                                   scheduling_strategy="SPREAD")
            self.actors = [group.remote(CloudpickleWrapper(
                (vectorize, env_fns[self.starts[k]:self.starts[k + 1]])))
                for k in range(actors)]
            try:
                found = ray.get([a.where.remote() for a in self.actors],
                                timeout=START_TIMEOUT_S)
            except ray.exceptions.GetTimeoutError:
                raise ClusterError(f"--ray {address}: {actors} actor(s) did not start in "
                                   f"{START_TIMEOUT_S:.0f} s; fix: set num_cpus to at most "
                                   f"the cluster's free CPUs ({cpus})") from None
            except (ray.exceptions.RayError, ImportError) as err:
                raise cannot_run_here(address, err) from None
            check_workers(found, address)
            self.hosts = sorted({w["host"] for w in found})
            self.remotes = [_ActorPipe(a) for a in self.actors]
            self.processes = []
            self.closed = False
            self.waiting = False
            spaces = self._ask_first("observation_space"), self._ask_first("action_space")
            VecEnv.__init__(self, n, *spaces)
        except BaseException:
            self._stop()
            raise

    def close(self) -> None:
        if not getattr(self, "closed", True):
            self.closed = True
            self._stop()

    def _stop(self) -> None:
        """Kill the actors (their work stops with them) and a Ray started here."""
        for actor in self.actors:
            try:
                ray.kill(actor, no_restart=True)
            except Exception:  # noqa: BLE001 - already gone
                pass
        self.actors = []
        if self._started:
            ray.shutdown()
            self._started = False
