"""Where the episodes run: ``Workers`` maps jobs over worker processes (each with its own
runner, one torch thread) or in this process for ``workers=1``, in job order either way, so
results do not depend on the number of workers; ``open_backend`` picks it or Ray's
(``training.runs.ray_backend``)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_completed
from concurrent.futures.process import BrokenProcessPool

from .base import (
    Backend,
    BackendError,
    WorkerLost,
    collect_less,
    default_workers,
    make_runner,
)
from .runner import EpisodeRunner

__all__ = ["Backend", "BackendError", "WorkerLost", "Workers", "default_workers",
           "make_runner", "open_backend"]


_RUNNER: EpisodeRunner | None = None
_JOB: Callable | None = None


def _init_worker(runner_args: tuple | None, job: Callable) -> None:
    global _RUNNER, _JOB
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle
    # Two torch threads per worker oversubscribe the cores (shared/PITFALLS.md): one thread
    # each. Not by importing torch here, which took 5 s a worker and most jobs (a heuristic
    # or a GA evaluator) never use: torch, when a job imports it, starts with
    # OMP_NUM_THREADS threads (torch.set_num_threads(1) does the same, once it is imported).
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)
    else:
        os.environ["OMP_NUM_THREADS"] = "1"
    _RUNNER, _JOB = make_runner(runner_args), job
    collect_less()  # a worker plays episode after episode: its imports and runner stay


def _call(args):
    return _JOB(_RUNNER, *args)


def _started() -> None:
    """A job that does nothing: submitted once per worker, it starts them all (see
    ``Workers.__enter__``)."""


class Workers(Backend):
    """``job(runner, *args)`` over worker processes of this machine, each with its own
    ``EpisodeRunner(*runner_args)`` (``runner_args`` None: the job gets None); one process (no
    pool) for ``workers=1``. A worker that dies takes the pool down: the unfinished jobs run
    again in a new pool, ``retries`` times; then one at a time, and ``WorkerLost`` names those
    whose worker still died (after every other result was handed out).
    ``job`` must be a module-level function (it is pickled by name)."""

    def __init__(self, job: Callable, runner_args: tuple | None, workers: int, retries: int = 1):
        self.job, self.runner_args, self.workers = job, runner_args, max(1, int(workers))
        self.retries = retries
        self.label = f"{self.workers} worker process(es)"
        self._pool = self._runner = None

    def _new_pool(self):
        ctx = multiprocessing.get_context("spawn")  # no forked torch or pygame state
        return ProcessPoolExecutor(self.workers, ctx, _init_worker, (self.runner_args, self.job))

    @property
    def runner(self) -> EpisodeRunner | None:
        """The runner of this process when the jobs run here (``workers=1``), else None."""
        return self._runner

    def __enter__(self) -> Workers:
        if self.workers == 1:
            self._runner = make_runner(self.runner_args)
        else:
            self._pool = self._start(self._new_pool())
        return self

    def _start(self, pool):
        """``pool`` with its worker processes started now, not at the first job: their
        imports and runners (seconds) overlap what this process does before it has jobs
        (a spawning pool starts a process at each submit while none is idle)."""
        for _ in range(self.workers):
            pool.submit(_started)
        return pool

    def as_completed(self, jobs: Iterable[tuple]) -> Iterator[tuple[int, object]]:
        jobs = list(jobs)
        if self._pool is None:
            for i, args in enumerate(jobs):
                yield i, self.job(self._runner, *args)
            return
        todo, tries = list(range(len(jobs))), 0
        while todo and tries <= self.retries:
            futures = {self._pool.submit(_call, jobs[i]): i for i in todo}
            finished = set()
            for future in futures_completed(futures):
                try:
                    result = future.result()
                except BrokenProcessPool:  # a worker died: its job and every unfinished one
                    continue
                finished.add(futures[future])
                yield futures[future], result
            todo = [i for i in todo if i not in finished]
            if todo:
                self._stop(self._pool)
                self._pool = self._new_pool()
                tries += 1
        # Still dying: one job at a time, so that only the job that kills its worker is lost.
        lost = []
        for i in todo:
            try:
                result = self._pool.submit(_call, jobs[i]).result()
            except BrokenProcessPool:
                lost.append(i)
                self._stop(self._pool)
                self._pool = self._new_pool()
                continue
            yield i, result
        if lost:
            raise WorkerLost(lost, self.retries)

    @staticmethod
    def _stop(pool) -> None:
        """Cancel what is queued and end the worker processes now (not after their jobs)."""
        processes = list(getattr(pool, "_processes", None) or {})  # pids; private, but
        # shutdown(cancel_futures=True) still waits for running jobs (3.14 adds terminate_workers)
        pool.shutdown(wait=False, cancel_futures=True)
        for pid in processes:
            try:
                os.kill(pid, signal.SIGTERM)
            except (ProcessLookupError, PermissionError):
                pass
        pool.shutdown(wait=True)  # the pool sees its workers gone and frees its queues

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            if exc[0] is None:
                self._pool.shutdown(wait=True)
            else:
                self._stop(self._pool)
            self._pool = None


def open_backend(job: Callable, runner_args: tuple | None, workers: int | None = None,
                 ray: str | None = None, retries: int = 1) -> Backend:
    """Where ``job(runner, *args)`` runs: worker processes of this machine (``ray`` None, the
    default; ``workers`` None: every core), or Ray actors (``ray="local"``: a Ray started
    here with ``workers`` CPUs; an address: that cluster, ``workers`` None: one actor per CPU
    of it). Ray is imported only in the second case (training/runs/ray_backend.py)."""
    if ray is None:
        return Workers(job, runner_args, workers or default_workers(), retries)
    from .ray_backend import RayWorkers

    return RayWorkers(job, runner_args, workers, ray, retries)
