"""How a local worker starts (``training.runs.backends``): one torch thread without importing
torch (5 s a worker that most jobs never use), and every worker started when the pool opens,
so that their imports overlap this process's own start."""

from __future__ import annotations

import os
import sys
import types

import pytest

from training.runs import backends


def _threads(runner) -> tuple[int, bool]:
    """In a worker: torch's intra-op threads once a job imports it, and whether the worker
    had imported torch before this job."""
    had = "torch" in sys.modules
    import torch

    return torch.get_num_threads(), had


def _pid(runner) -> int:
    return os.getpid()


def test_a_worker_leaves_torch_unimported_but_at_one_thread(monkeypatch):
    """Without torch imported: OMP_NUM_THREADS=1, which torch reads when a job imports it.
    With torch imported already: its ``set_num_threads(1)``."""
    monkeypatch.setattr(backends.signal, "signal", lambda *a: None)  # not this process's
    monkeypatch.delitem(sys.modules, "torch", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    backends._init_worker(None, _pid)
    assert os.environ["OMP_NUM_THREADS"] == "1"
    assert "torch" not in sys.modules
    assert backends._call(()) == os.getpid()

    calls = []
    monkeypatch.delenv("OMP_NUM_THREADS")
    monkeypatch.setitem(sys.modules, "torch", types.SimpleNamespace(set_num_threads=calls.append))
    backends._init_worker(None, _pid)
    assert calls == [1] and "OMP_NUM_THREADS" not in os.environ


# slow: two workers spawn and each imports torch (about 10 s on the shared 2 cores)
@pytest.mark.slow
def test_workers_are_started_on_entry_and_torch_runs_on_one_thread():
    with backends.Workers(_threads, None, 2) as pool:
        assert len(pool._pool._processes) == 2  # before any job
        assert pool.map([(), ()]) == [(1, False), (1, False)]


def test_collecting_less_inside_the_block_and_as_before_after():
    import gc

    from training.runs.base import FEW_COLLECTIONS, collecting_less

    before, frozen = gc.get_threshold(), gc.get_freeze_count()
    with collecting_less():
        assert gc.get_threshold() == (FEW_COLLECTIONS, *before[1:])
        assert gc.get_freeze_count() > frozen  # this process's objects out of its reach
    assert gc.get_threshold() == before and gc.get_freeze_count() == 0
