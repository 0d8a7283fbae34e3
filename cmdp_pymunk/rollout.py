"""Playing episodes: the loop every command, search and evaluation drives a floor with.

``play`` drives an engine from where it stands to the end of its episode (the lookahead's
branches too); ``run_episode`` resets it with a seed, plays it with a progress bar and frames
and returns the ``Episode`` (with ``report.stall_report`` when it stalled). What a run folder
records of an episode (the stall report, the crew summary, reach rate, percentiles, versions)
is ``cmdp_pymunk.report``. Everything here takes an engine and addresses crews by index.

The low level is a ``policy.LowLevel`` (``bind``, ``reset``, ``actions``; the implementations
are in ``agents``); this module needs nothing from ``agents``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .engine import Engine
from .interrupt import sigint_guard
from .observe import ReachingObservations
from .policy import LowLevel, ShowsWay
from .report import stall_report
from .state import CrewStatus


@dataclass
class Episode:
    """One finished (or stopped) episode: its seed, makespan (None unless every task ended),
    wall-clock seconds, the stall report if it stalled, and any rendered frames."""

    seed: int
    makespan_s: float | None
    wall_s: float
    stalled: dict | None
    frames: list = field(default_factory=list)


def play(engine: Engine, low_level: LowLevel, reaching: ReachingObservations | None = None,
         before_step: Callable[[], None] | None = None,
         pause: Callable[[], bool] | None = None) -> None:
    """Drive ``engine`` from where it stands to the end of its episode (every task ended, the
    time limit or the stall guard): the low level's actions on this second's observations
    (cast by ``reaching`` if it ``reads_rays``), then on to the next second at which a crew
    needs a decision (the idle jump). ``before_step`` is called before each step (frames).
    A floor without a low level (the event floor) runs to its end in one go, or, with
    ``pause``, stops after the first event at which ``pause()`` holds (a frame is due) to
    call ``before_step`` again."""
    n = len(engine.site.crews)
    if not engine.motion.takes_actions:  # the walk motion: crews walk, no low level acts
        until = pause or _never
        while True:
            if before_step is not None:
                before_step()
            run = engine.advance(None, until=until)
            if run.terminated or run.truncated:
                return
    while True:
        if before_step is not None:
            before_step()
        obs = [reaching.crew(engine, i) for i in range(n)] if reaching is not None else None
        run = engine.advance(low_level.actions(engine, obs), until=engine.decision_due)
        if run.terminated or run.truncated:
            return


def _never() -> bool:
    return False


def run_episode(engine: Engine, low_level: LowLevel, seed: int, stall_s: float | None,
                progress: bool = True, frame_every_s: float | None = None,
                on_frame: Callable[[np.ndarray], None] | None = None,
                render: Callable[[Engine], np.ndarray] | None = None) -> Episode:
    """Run one episode of ``engine`` to its end, a time-out or a stall; frames every
    ``frame_every_s``.

    Args:
        engine: the floor (reset here with ``seed``).
        low_level: the reaching policy (``policy.LowLevel``): bound to the engine, then
            ``reset(seed)`` after the engine's reset; its rays are cast only if it reads them.
        seed: the episode's seed.
        stall_s: stop when no task moves on for this many simulated seconds: sets the engine's
            stall guard (``engine.stall_s``, the one training uses); None keeps the engine's.
        progress: show a tqdm bar of the tasks ended (the simulated time beside it).
        frame_every_s: draw a frame every this many simulated seconds (None: no frames) with
            ``render(engine)`` (e.g. ``media.render.draw_frame``).
        on_frame: where each frame goes as it is drawn (e.g. ``media.gif.GifStream.append``,
            so that no frame is held); None keeps them in ``Episode.frames``.
    """
    from tqdm import tqdm

    if stall_s is not None:
        if not (math.isfinite(stall_s) and stall_s > 0):
            raise ValueError(f"stall_s must be a positive finite number of seconds, not "
                             f"{stall_s!r}")
        engine.stall_s = stall_s
    if frame_every_s is not None and render is None:
        raise ValueError("run_episode: frame_every_s needs render(engine), e.g. "
                         "media.render.draw_frame")
    acts = engine.motion.takes_actions  # the walk motion needs no low level
    if acts:
        low_level.bind(engine)
    engine.reset(seed)
    if acts:
        low_level.reset(seed)
    reaching = ReachingObservations(engine.case) if acts and low_level.reads_rays else None
    site = engine.site
    frames: list = []
    keep = frames.append if on_frame is None else on_frame
    next_frame = [0.0]
    # counted in tasks ended, the one total known in advance (a floor's simulated seconds are
    # not: against the time limit, a finished floor stopped the bar at about 40 %)
    bar = tqdm(total=len(site.tasks), unit="task", disable=not progress, leave=False,
               mininterval=1.0, desc=f"seed {seed}")
    ended = [0]

    def before_step() -> None:
        if frame_every_s is not None:
            while site.time_s >= next_frame[0]:  # a jump repeats the still frame: time-lapse
                keep(render(engine))
                next_frame[0] += frame_every_s
        bar.update(site.tasks_ended - ended[0])
        ended[0] = site.tasks_ended
        bar.set_postfix_str(f"t = {site.time_s:,.0f} s", refresh=False)

    # a floor that jumps from event to event stops at the first event after a frame is due
    pause = (lambda: site.time_s >= next_frame[0]) if frame_every_s is not None else None
    start = time.perf_counter()
    with sigint_guard(), bar:  # Ctrl-C stops the loop even when it lands inside pymunk
        play(engine, low_level, reaching, before_step, pause)
    stalled = stall_report(engine, engine.stalled["after_s"], _ways(engine, low_level)) \
        if engine.stalled else None
    if frame_every_s is not None:
        keep(render(engine))
    return Episode(seed, engine.makespan_s, time.perf_counter() - start, stalled, frames)


def _ways(engine: Engine, low_level: LowLevel) -> dict | None:
    """Each walking crew's intended way, from a low level that can say it."""
    if not isinstance(low_level, ShowsWay):
        return None
    return {c.index: low_level.way(engine, c.index) for c in engine.site.crews
            if c.status != CrewStatus.LEFT}
