"""Episodes as rows of numbers, in this process or in worker processes: what the GA and
``cmdp-evaluate`` share.

``episode_row`` sums up one finished (or stopped) episode: makespan, reaching steps, idle
steps by cause, crane waits, whether it stalled or timed out, and when each task ended.
``EpisodeRunner`` holds one engine and low level per (evaluator, navigator) pair and runs seeds
on them; ``Workers`` maps jobs over worker processes (each with its own runner, one torch
thread) or in this process for ``workers=1``, in job order either way, so results do not
depend on the number of workers.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_completed
from concurrent.futures.process import BrokenProcessPool

from cmdp_pymunk.engine import Engine
from cmdp_pymunk.rollout import Episode, episode_reach_rate, run_episode
from cmdp_pymunk.schedule import finish_times
from cmdp_pymunk.state import DISRUPTION_CAUSES, DISRUPTION_IDLE_FIELDS

from .models import PolicyStuck
from .specs import make_evaluator, make_navigator

ROW_FIELDS = ("makespan_s", "finished", "stalled", "timed_out", "tasks_finished",
              "simulated_s", "reaching_steps", "idle_waiting_for_predecessor",
              "idle_blocked_by_task_area", "idle_no_target", "idle_steps", "crane_waits",
              "crane_wait_s", "reach_rate", "wall_s", "stall_reason",
              # crew-seconds a disruption kept crews from working (``disruptions``), by kind
              *DISRUPTION_IDLE_FIELDS)
# Beside ROW_FIELDS, in every row (episodes.jsonl) but not in episodes.csv (a list per cell):
# the simulated second each task ended, in increasing order, for the S-curve of a comparison.
TASK_END_TIMES = "task_end_times_s"


def task_end_times(engine: Engine) -> list[float]:
    """When each task ended (``schedule.finish_times`` of the engine's event log), in seconds,
    rounded to the millisecond to keep ``episodes.jsonl`` short."""
    return [round(t, 3) for t in finish_times(engine.log.events)]


def episode_row(engine: Engine, episode: Episode | None, stall_reason: str = "") -> dict:
    """One episode's numbers, summed over the crews (``ROW_FIELDS``), from ``engine``.
    ``episode`` None: the low level raised (``stall_reason`` says what); the episode counts as
    stalled."""
    site = engine.site
    crews = site.crews
    idle = {cause: sum(c.stats.idle_steps[cause] for c in crews) for cause in (1, 2, 3)}
    stalled = episode is None or episode.stalled is not None
    if episode is not None and episode.stalled is not None:
        stall_reason = (f"no task moved on for {episode.stalled['after_s']:.0f} s "
                        f"(t = {episode.stalled['time_s']:.0f} s)")
    return {
        "makespan_s": episode.makespan_s if episode is not None else None,
        "finished": bool(site.done),
        "stalled": stalled,
        "timed_out": not site.done and not stalled,
        "tasks_finished": site.tasks_ended,
        "simulated_s": site.time_s,
        "reaching_steps": sum(c.stats.reaching_steps for c in crews),
        "idle_waiting_for_predecessor": idle[1],
        "idle_blocked_by_task_area": idle[2],
        "idle_no_target": idle[3],
        "idle_steps": sum(idle.values()),
        "crane_waits": sum(c.stats.crane_waits for c in crews),
        "crane_wait_s": sum(c.stats.crane_wait_steps for c in crews),
        "reach_rate": round(episode_reach_rate(engine), 4),
        "wall_s": round(episode.wall_s, 3) if episode is not None else None,
        "stall_reason": stall_reason,
        **{f"idle_{c.name.lower()}": sum(crew.stats.idle_steps[c] for crew in crews)
           for c in DISRUPTION_CAUSES},
        TASK_END_TIMES: task_end_times(engine),
    }


def make_engine(case, evaluator, navigator_spec: str, max_time_s: float | None = None,
                position_log_every_s: float | None = None) -> Engine:
    """The stage-2 floor as ``cmdp-simulate`` builds it: the scripted navigator lets the engine
    skip parked crews' seconds (``park_idle``); a trained navigator decides for every crew.
    ``position_log_every_s``: moving crews' positions in the event log (trajectories)."""
    return Engine(case, stage=2, evaluator=evaluator, max_time_s=max_time_s,
                  park_idle=navigator_spec == "scripted",
                  position_log_every_s=position_log_every_s)


class EpisodeRunner:
    """Engines and low levels kept per (evaluator, navigator) pair; ``run`` plays one seed.

    An evaluator is a spec (``agents.specs.make_evaluator``) or an evaluator object (the GA
    passes its individuals); an object is swapped into a cached engine of the same navigator.
    ``position_log_every_s``: see ``make_engine``.
    """

    def __init__(self, case, stall_s: float | None = 3600.0, max_time_s: float | None = None,
                 deterministic: bool = False, position_log_every_s: float | None = None):
        self.case = case
        self.stall_s = stall_s
        self.max_time_s = max_time_s
        self.deterministic = deterministic
        self.position_log_every_s = position_log_every_s
        self._cache: dict = {}
        self.playing = None  # the engine of the episode under way in ``play`` (for its time)

    def _engine(self, evaluator, navigator_spec: str):
        key = (evaluator if isinstance(evaluator, str) else "<object>", navigator_spec)
        if key not in self._cache:
            ev = make_evaluator(evaluator) if isinstance(evaluator, str) else evaluator
            engine = make_engine(self.case, ev, navigator_spec, self.max_time_s,
                                 self.position_log_every_s)
            self._cache[key] = (engine, make_navigator(navigator_spec, engine,
                                                       self.deterministic))
        engine, navigator = self._cache[key]
        if not isinstance(evaluator, str):
            engine.evaluator = evaluator
        return engine, navigator

    def run(self, evaluator, navigator_spec: str, seed: int) -> dict:
        engine, navigator = self._engine(evaluator, navigator_spec)
        try:
            episode = run_episode(engine, navigator, seed, self.stall_s, progress=False)
        except PolicyStuck as err:
            return episode_row(engine, None, str(err))
        return episode_row(engine, episode)

    def play(self, evaluator, navigator_spec: str, seed: int, progress: bool = False):
        """One seed played on the cached engine: ``(engine, Episode)``, the engine left at the
        episode's end for whoever reads its log; ``PolicyStuck`` passes through."""
        engine, navigator = self._engine(evaluator, navigator_spec)
        self.playing = engine
        return engine, run_episode(engine, navigator, seed, self.stall_s, progress=progress)


def check_specs(case, strategies: list[str], navigators: list[str],
                deterministic: bool) -> None:
    """Build every evaluator and low level once on the case: a missing file or a model or
    priority file that does not fit the case fails here, before any episode."""
    for spec in strategies:
        make_engine(case, make_evaluator(spec), "scripted")
    for spec in navigators:
        make_navigator(spec, make_engine(case, "priority", spec), deterministic)


def check_worker(runner: EpisodeRunner, strategies: list[str], navigators: list[str],
                 deterministic: bool) -> str:
    """``check_specs`` in a (Ray) worker, through ``Backend.check_each``: its files are the
    ones that count. An error as one line naming the worker's host ("" if all is well)."""
    import socket

    try:
        check_specs(runner.case, strategies, navigators, deterministic)
    except (ValueError, OSError) as err:
        return f"on worker host {socket.gethostname()}: {err}"
    return ""


# -- where the episodes run ---------------------------------------------------------------------

_RUNNER: EpisodeRunner | None = None
_JOB: Callable | None = None


def _init_worker(runner_args: tuple | None, job: Callable) -> None:
    global _RUNNER, _JOB
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle
    try:  # two torch threads per worker oversubscribe the cores (shared/PITFALLS.md)
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass
    _RUNNER, _JOB = make_runner(runner_args), job


def _call(args):
    return _JOB(_RUNNER, *args)


def make_runner(runner_args: tuple | None) -> EpisodeRunner | None:
    """``EpisodeRunner(*runner_args)``; None for jobs that build their own floor (labelling)."""
    return None if runner_args is None else EpisodeRunner(*runner_args)


def default_workers() -> int:
    """Every core this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class BackendError(ValueError):
    """The backend cannot run the jobs (Ray missing, a cluster that does not answer, workers
    without this package); raised before any job, its message names the cause and the fix."""


class WorkerLost(RuntimeError):
    """Jobs whose worker died more often than ``retries`` allows; ``lost`` holds their indices
    in the job list. Raised after every other job's result was handed out."""

    def __init__(self, lost: list[int], retries: int):
        self.lost = sorted(lost)
        super().__init__(f"{len(self.lost)} job(s) lost: their worker died "
                         f"{retries + 1} time(s) while running them")


class Backend:
    """What every backend offers: ``as_completed`` (results as they arrive, with their index),
    ``imap``/``map`` (results in job order, so they do not depend on the backend or the
    number of workers) and ``check_each`` (a function run once in every worker, to find a
    worker that cannot run the jobs before any job runs). Use as a context manager."""

    workers: int
    label: str

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass

    def as_completed(self, jobs: Iterable[tuple]) -> Iterator[tuple[int, object]]:
        raise NotImplementedError

    def check_each(self, fn: Callable, *args) -> list:
        """``fn(runner, *args)`` in every worker; their answers (local processes: none, they
        share this machine's files and packages)."""
        return []

    def imap(self, jobs: Iterable[tuple]) -> Iterator:
        """Results one at a time, in job order (for a progress bar)."""
        waiting: dict[int, object] = {}
        nxt = 0
        for i, result in self.as_completed(jobs):
            waiting[i] = result
            while nxt in waiting:
                yield waiting.pop(nxt)
                nxt += 1

    def map(self, jobs: Iterable[tuple]) -> list:
        return list(self.imap(jobs))


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
            self._pool = self._new_pool()
        return self

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
    of it). Ray is imported only in the second case (agents/ray_backend.py)."""
    if ray is None:
        return Workers(job, runner_args, workers or default_workers(), retries)
    from .ray_backend import RayWorkers

    return RayWorkers(job, runner_args, workers, ray, retries)
