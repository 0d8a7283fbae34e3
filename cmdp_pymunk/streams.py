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
import threading

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
        return generator_of(self.key(source, item))

    def pace(self, task: int) -> PaceStream | ExpectedDraws:
        """The stream a task's pace is drawn from (``construct.draw_pace``; a
        ``PaceStream``, a numpy Generator to its caller); in the ``EXPECTED`` scenario,
        draws that give the mean."""
        if self.scenario == EXPECTED:
            return ExpectedDraws()
        return PaceStream(tuple(self.key(PACE, task)))


# numpy's SeedSequence (``numpy.random.bit_generator``) and PCG64 seeding constants: numpy
# keeps both streams stable across versions (NEP 19), and ``_numpy_agrees`` checks it here
_M32, _M128 = 0xFFFFFFFF, (1 << 128) - 1
_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R = np.uint32(0xCA01F9DD), np.uint32(0x4973F715)
_PCG_MULT = 0x2360ED051FC65DA44385DF649FCCF645
BLOCK = 32  # tasks whose first normals are worked out together (``_first_normal``)


def _words(key: tuple[int, ...]) -> list[int]:
    """The key as SeedSequence reads it: each int as 32-bit words, low first (0 as one)."""
    out = []
    for n in key:
        if n == 0:
            out.append(0)
        while n:
            out.append(n & _M32)
            n >>= 32
    return out


def _hash_constants(count: int, init: int, mult: int) -> list[np.uint32]:
    # SeedSequence's hash constant moves on by one multiplication per word hashed, whatever
    # the word: the same sequence for every key
    h, out = init, []
    for _ in range(count):
        out.append(np.uint32(h))
        h = (h * mult) & _M32
    return out


def _pcg64_states(keys: list[tuple[int, ...]]) -> list[tuple[int, int]]:
    """PCG64's (state, increment) as ``PCG64(SeedSequence(key))`` sets them, for keys of one
    length in words, worked out together.

    Making the SeedSequence and the PCG64 objects costs 20-35 us a stream, most of it numpy's
    per-call machinery (an ``errstate`` per SeedSequence), and a floor starts one stream per
    task; the same hash on arrays of keys costs a few us a key. SeedSequence: the words hashed
    into a pool of four (``mix_entropy``), eight words drawn from it (``generate_state(4,
    uint64)``), in uint32 arithmetic (numpy's wraps as C's); PCG64 (``pcg64_set_seed``):
    state 0, increment ``2 * seq + 1``, one step, the initial state added, one step."""
    words = np.array([_words(k) for k in keys], dtype=np.uint32)
    width = words.shape[1]
    ha = iter(_hash_constants(4 + 12 + 4 * max(0, width - 4) + 1, _INIT_A, _MULT_A))
    h = next(ha)
    shift = np.uint32(16)

    def hashmix(x: np.ndarray) -> np.ndarray:
        nonlocal h
        v = x ^ h
        h = next(ha)
        v = v * h
        return v ^ (v >> shift)

    def mix(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        r = _MIX_L * x - _MIX_R * y
        return r ^ (r >> shift)

    zero = np.zeros(len(keys), dtype=np.uint32)
    pool = [hashmix(words[:, i] if i < width else zero) for i in range(4)]
    for src in range(4):
        for dst in range(4):
            if src != dst:
                pool[dst] = mix(pool[dst], hashmix(pool[src]))
    for src in range(4, width):
        for dst in range(4):
            pool[dst] = mix(pool[dst], hashmix(words[:, src]))
    hb = _hash_constants(9, _INIT_B, _MULT_B)
    drawn = []
    for i in range(8):
        v = (pool[i & 3] ^ hb[i]) * hb[i + 1]
        drawn.append(v ^ (v >> shift))
    out = []
    for o in np.stack(drawn, axis=1).tolist():
        initstate = (o[0] | o[1] << 32) << 64 | o[2] | o[3] << 32
        inc = (((o[4] | o[5] << 32) << 64 | o[6] | o[7] << 32) << 1 | 1) & _M128
        state = (inc + initstate) & _M128  # the first step from state 0 is the increment
        out.append(((state * _PCG_MULT + inc) & _M128, inc))
    return out


_BITS = np.random.PCG64(0)  # one generator, its state set per stream (``_first_normals``)
_DRAW = np.random.Generator(_BITS)
_SET_AND_DRAW = threading.Lock()  # each set and its draw as one, should threads share it


def _first_normals(keys: list[tuple[int, ...]]) -> list[float]:
    """The first standard normal of each stream ``keys`` (one length in words), numpy's to
    the bit (``_pcg64_states``, then numpy's own draw)."""
    out = []
    with _SET_AND_DRAW:
        for state, inc in _pcg64_states(keys):
            _BITS.state = {"bit_generator": "PCG64", "state": {"state": state, "inc": inc},
                           "has_uint32": 0, "uinteger": 0}
            out.append(_DRAW.standard_normal())
    return out


def generator_of(key) -> np.random.Generator:
    """The numpy generator of the stream ``key`` (a SeedSequence key: ints)."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(list(key))))


def _numpy_first_normal(key: tuple[int, ...]) -> float:
    return generator_of(key).standard_normal()


@functools.cache
def _numpy_agrees() -> bool:
    """Whether ``_first_normals`` seeds as this numpy does (checked once per process on keys
    of every shape a floor asks; numpy's own path is taken if not)."""
    keys = ((0, PACE, 0), (7, PACE, 86, 2), (2**64 + 5, PACE, 3, 1, 12), (2**127 - 1, 2, 9))
    return all(_first_normals([k]) == [_numpy_first_normal(k)] for k in keys)


_KEPT: dict[tuple[int, ...], float] = {}  # stream key -> its first standard normal
_KEPT_MAX = 1 << 16


def _first_normal(key: tuple[int, ...]) -> float:
    """The first standard normal of the stream ``key`` (kept: see ``PaceStream``). A key not
    kept yet brings its block's: the ``BLOCK`` tasks around it, in the same future (a floor
    starts every task of its seed, a branch most of those not started)."""
    z = _KEPT.get(key)
    if z is not None:
        return z
    if len(_KEPT) >= _KEPT_MAX:
        _KEPT.clear()
    if not _numpy_agrees():
        z = _KEPT[key] = _numpy_first_normal(key)
        return z
    head, item, tail = key[:2], key[2], key[3:]
    first = item - item % BLOCK
    block = [(*head, i, *tail) for i in range(first, first + BLOCK)]
    _KEPT.update(zip(block, _first_normals(block), strict=True))
    return _KEPT[key]


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
            self._rng = generator_of(self._key)
            if self._drawn:
                self._rng.standard_normal()  # the first draw, given from the kept one
        return self._rng

    def __getattr__(self, name: str):
        return getattr(self.generator(), name)
