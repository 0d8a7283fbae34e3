"""What every backend shares: the protocol (``Backend``), its errors, the runner a worker
builds, and the cores this process may use. Neither backend is imported here, so the process
backend and the Ray backend both build on it without importing each other."""

from __future__ import annotations

import contextlib
import gc
import os
from collections.abc import Callable, Iterable, Iterator

from .runner import EpisodeRunner


def make_runner(runner_args: tuple | None) -> EpisodeRunner | None:
    """``EpisodeRunner(*runner_args)``; None for jobs that build their own floor (labelling)."""
    return None if runner_args is None else EpisodeRunner(*runner_args)


# Allocations between two collections of the cyclic garbage collector's youngest generation
# while episodes are played and written (Python's default: 700).
FEW_COLLECTIONS = 20_000


def collect_less() -> tuple[int, ...]:
    """The cyclic garbage collector made cheap for a process that plays or writes many
    episodes: what exists now (modules, the case, the engines: never garbage) is frozen out of
    its reach, and its youngest generation is collected every ``FEW_COLLECTIONS`` allocations.
    An event log is thousands of tuples that live until their seed is written, so each of the
    default's collections walked them again; with the modules walked by each full collection,
    that was a tenth of writing 1,000 seeds' files. Returns the thresholds it replaced."""
    gc.freeze()
    before = gc.get_threshold()
    gc.set_threshold(FEW_COLLECTIONS, *before[1:])
    return before


@contextlib.contextmanager
def collecting_less():
    """``collect_less`` inside the block, the collector as it was after it."""
    before = collect_less()
    try:
        yield
    finally:
        gc.set_threshold(*before)
        gc.unfreeze()


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
