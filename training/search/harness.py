"""What the searches over whole floors share (the GA, the CMA-ES rule search), as PPO's runs
share ``training.scaffold``: the run folder and its checkpoint (``start``), a progress bar with
a true total that resumes where the run stopped (``progress_bar``), the episodes on a backend
with the searches' random generators kept across its start (``episodes``), and the history
file (``write_history``). What differs (the genes or the rule's weights, how a generation is
made and scored) stays in ``genetic`` and ``rule``.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

import numpy as np
from pydantic import BaseModel

from cmdp_pymunk.events import write_atomic

from ..runs.backends import open_backend
from ..runs.checkpoint import resume_state

CHECKPOINT = "checkpoint.pkl"
State = TypeVar("State")


def start(out: Path, config: BaseModel, resume: bool, new_state: Callable[[], State]) -> State:
    """The run folder made, and the search's state: the checkpoint's with ``resume`` (which
    must come from the same config, up to ``generations``: ``resume_state``), else a new one."""
    out.mkdir(parents=True, exist_ok=True)
    return resume_state(out / CHECKPOINT, config) if resume else new_state()


def progress_bar(total: int, done: int, unit: str, desc: str, progress: bool):
    """A tqdm bar over every episode of the whole run, starting at those already played."""
    from tqdm import tqdm

    return tqdm(total=total, initial=min(done, total), unit=unit, desc=desc,
                disable=not progress, mininterval=1.0)


@contextmanager
def episodes(job: Callable, runner_args: tuple, workers: int | None, ray: str | None, bar,
             state) -> Iterator[Callable[[list[tuple]], list]]:
    """Open the backend (``training.runs.backends.open_backend``) and yield ``play(jobs)``: the
    jobs' rows in job order, each counted on ``bar`` and in ``state.evaluations``.

    DEAP draws from the stdlib's ``random`` and CMA-ES from numpy's global generator; starting
    Ray draws from ``random`` too, so both generators are kept across the backend's start and
    a search is the same on any backend."""
    kept = random.getstate(), np.random.get_state()
    with open_backend(job, runner_args, workers, ray) as pool:
        random.setstate(kept[0])
        np.random.set_state(kept[1])

        def play(jobs: list[tuple]) -> list:
            rows = []
            for row in pool.imap(jobs):
                rows.append(row)
                bar.update(1)
            state.evaluations += len(jobs)
            return rows

        yield play


def write_history(out: Path, header: str, lines: list[str]) -> None:
    """``out/history.csv``: the header and one line a generation, written atomically."""
    write_atomic(out / "history.csv", "\n".join([header, *lines]) + "\n")
