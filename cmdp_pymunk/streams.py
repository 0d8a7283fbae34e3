"""Random streams per source: common random numbers for paired comparisons and branching.

Each source of randomness draws from its own stream, keyed by the episode's seed, the source
and the item (``numpy.random.SeedSequence``). A task's pace (Table 3) comes from the stream
of (seed, "pace", task), whatever the order in which tasks start: two strategies run on one
seed meet the same duration for the same task, and a different decision early in the floor
does not reshuffle every later duration (one generator drawn in task-start order did).

A *scenario* is a sampled future of a floor (``Engine.clone(scenario=k)``): the paces of tasks
not yet started come from (seed, "pace", k, task) instead; tasks already started keep the
pace they drew. Scenario None is the floor's own future. Scenario ``EXPECTED`` is the
certainty-equivalent future: every task not yet started works at its expected pace (a normal
draw of Table 3 gives its mean), so one branch stands for the average future without the
noise of sampling one (other sources, e.g. disruptions, keep drawing from a stream of their own
for it).

Disruptions (``disruptions``) draw from (seed, kind, entry): each kind of disruption its own
source, so adding one leaves every task's pace, and every other kind's draws, unchanged.
"""

from __future__ import annotations

import functools

import numpy as np

# Source ids: a new source takes a new number, so adding one changes no other stream.
PACE = 1
# Disruptions (``disruptions``): each kind its own source, each entry of the case's list an item.
CRANE_BREAKDOWN = 2
LATE_DELIVERY = 3
ABSENCE = 4
WEATHER = 5

# The scenario of expected paces (``RandomStreams.with_scenario``): not a sampled future.
EXPECTED = -1


class ExpectedDraws:
    """Stands in for a task's pace generator in the ``EXPECTED`` scenario: a normal draw is
    its mean (``construct.draw_pace`` then gives the expected pace of Table 3)."""

    def normal(self, loc: float = 0.0, scale: float = 1.0) -> float:
        return float(loc)


class RandomStreams:
    """The streams of one episode: ``pace(task)`` gives the generator of a task's pace.

    Args:
        seed: the episode's seed (an int >= 0), or None for fresh OS entropy (then
            ``entropy`` says which, so the episode can be replayed).
        scenario: None for the floor's own future, an int >= 0 naming a sampled one, or
            ``EXPECTED`` (every task not yet started at its expected pace).
    """

    def __init__(self, seed: int | None, scenario: int | None = None):
        if seed is not None and (not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed must be an int >= 0 or None, not {seed!r}")
        self.entropy = int(seed) if seed is not None else int(np.random.SeedSequence().entropy)
        self.seed = seed
        self.scenario = None
        self.with_scenario(scenario)

    def with_scenario(self, scenario: int | None) -> RandomStreams:
        """Switch the future to scenario ``scenario`` (in place; returns self)."""
        if scenario is not None and (not isinstance(scenario, (int, np.integer))
                                     or (scenario < 0 and scenario != EXPECTED)):
            raise ValueError(f"scenario must be an int >= 0, None (the floor's own future) or "
                             f"streams.EXPECTED ({EXPECTED}: expected paces), not {scenario!r}")
        self.scenario = None if scenario is None else int(scenario)
        return self

    def key(self, source: int, item: int) -> list[int]:
        """The SeedSequence key of one item of one source under the current scenario."""
        if self.scenario is None:
            return [self.entropy, source, item]
        if self.scenario == EXPECTED:
            return [self.entropy, source, item, 2]
        return [self.entropy, source, item, 1, self.scenario]

    def generator(self, source: int, item: int) -> np.random.Generator:
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.key(source,
                                                                                    item))))

    def pace(self, task: int) -> PaceStream | ExpectedDraws:
        """The stream a task's pace is drawn from (``construct.draw_pace``; a
        ``PaceStream``, a numpy Generator to its caller); in the ``EXPECTED`` scenario,
        draws that give the mean."""
        if self.scenario == EXPECTED:
            return ExpectedDraws()
        return PaceStream(tuple(self.key(PACE, task)))


@functools.lru_cache(maxsize=1 << 14)
def _first_normal(key: tuple[int, ...]) -> float:
    """The first standard normal of the stream ``key`` (kept: see ``PaceStream``)."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(list(key)))) \
        .standard_normal()


class PaceStream:
    """A task's pace stream: what ``RandomStreams.generator`` gives for it, draw for draw.

    A pace is one normal draw (``construct.pace_of``), and the same stream's first draw is
    asked many times in one process: by a floor and by its seed's bound
    (``bounds.seed_lower_bound``), by the branches of a lookahead, by both floors of one seed.
    Making a generator (its SeedSequence and PCG64) costs more than the rest of starting a
    task, so the first standard normal of each stream is kept per process and a first
    ``normal(loc, scale)`` is ``loc + scale * z``, as numpy's own normal computes it (the
    same float: a test compares them). Anything else asked of it, or a second draw, goes to
    the stream's own generator, past the first draw if that was given."""

    __slots__ = ("_key", "_rng", "_drawn")

    def __init__(self, key: tuple[int, ...]):
        self._key = key
        self._rng: np.random.Generator | None = None
        self._drawn = False  # the first normal was given from the kept one

    def normal(self, loc: float = 0.0, scale: float = 1.0):
        if self._rng is None and not self._drawn and np.isscalar(loc) and np.isscalar(scale):
            self._drawn = True
            return loc + scale * _first_normal(self._key)
        return self.generator().normal(loc, scale)

    def generator(self) -> np.random.Generator:
        """The stream's numpy Generator, where the draws given so far left it."""
        if self._rng is None:
            self._rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(
                list(self._key))))
            if self._drawn:
                self._rng.standard_normal()  # the first draw, given from the kept one
        return self._rng

    def __getattr__(self, name: str):
        return getattr(self.generator(), name)
