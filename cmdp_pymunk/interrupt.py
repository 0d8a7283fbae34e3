"""Ctrl-C that is never lost inside pymunk's callbacks.

pymunk calls back into Python from C through cffi (a crew's ``velocity_func`` every substep,
the collision callbacks). A ``KeyboardInterrupt`` raised in one of them is printed as
"Exception ignored from cffi callback" and dropped, and the run goes on: 2 Ctrl-C in 10
landed there in a 2 s run. ``World.step`` therefore runs the physics between ``enter()`` and
``leave()``; while it is inside, the handler that ``sigint_guard()`` installs only records the
signal, and ``leave()`` raises ``KeyboardInterrupt`` in plain Python once ``space.step`` has
returned. Outside the physics the handler raises at once, as Python's own does.

Without ``sigint_guard()`` (Python's default handler) nothing changes: ``enter``/``leave`` only
count. ``rollout.run_episode`` and the command-line tools open the guard.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

_depth = 0  # > 0 while pymunk may call back into Python
_pending = False  # a SIGINT arrived while _depth > 0


def _handler(signum, frame) -> None:
    global _pending
    if _depth:
        _pending = True  # raising here would be swallowed by cffi
    else:
        raise KeyboardInterrupt


def enter() -> None:
    """The physics starts: a SIGINT from now on is held until ``leave()``."""
    global _depth
    _depth += 1


def leave() -> None:
    """The physics is done: raise ``KeyboardInterrupt`` if a SIGINT was held meanwhile."""
    global _depth, _pending
    _depth -= 1
    if _pending and not _depth:
        _pending = False
        raise KeyboardInterrupt


@contextmanager
def sigint_guard():
    """Install the holding SIGINT handler for the block, then put the previous one back.

    Does nothing outside the main thread (only it can set signal handlers), when the handler
    is already ours (nested guards) or when SIGINT is ignored (a background job, a training
    worker process)."""
    global _pending
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) in (_handler, signal.SIG_IGN):
        yield
        return
    previous = signal.signal(signal.SIGINT, _handler)
    _pending = False
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if _pending:  # held in a physics step that never returned to leave()
            _pending = False
            raise KeyboardInterrupt
