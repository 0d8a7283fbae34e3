"""Disruptions: crane breakdowns, late deliveries, absent crews and weather stops.

Beyond the paper (its limitations name uncertainty beyond task durations). The case's
``[disruptions]`` (``cases.model.Disruptions``, docs/disruptions.md) lists entries of four kinds;
each entry becomes *windows* ``[start_s, end_s)`` of simulated time, all drawn when the episode
starts (``Timeline``): a scheduled entry at ``at_s`` (repeated every ``every_s``), a random one
with exponential gaps of mean ``mean_interval_s`` after the end of the previous occurrence and
durations from ``duration_gamma``. Each kind draws from its own stream (``streams``: seed,
kind, entry), so adding a disruption changes no task's pace and no other disruption.

What a window does, for every second that *starts* inside it (``Now`` is the state read by
``construct`` for the next second; the engine sets it at the end of each second):

- crane breakdown: the crane serves nothing: the request it serves keeps its remaining time and
  its queue waits;
- late delivery: no lift restocks that storage: a lift for it waits in the crane's queue
  while the crane serves the requests behind it, and starts once the delivery has arrived;
- absence: the crew leaves the plane where it stands (its body leaves the physics) and comes
  back there; meanwhile it moves, decides, works and fetches nothing, and its task, area and
  crane request wait for it;
- weather stop: all outdoor work halts: no task progresses, no crew fetches, the crane
  serves nothing. Crews may still walk.

A crew that a disruption keeps from working is idle with the disruption as its cause
(``blocking_cause``; the Gantt activity ``idle_<kind>``, the idle time by cause). A case
without disruptions never builds a timeline: it runs exactly as before.

What struck an episode is read back from its event log (``struck``: how many of each kind,
and for how long); what they cost is the makespan against the same seed on the case without
them (``undisrupted``): every task meets the same pace in both, so the difference is the
disruptions' alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import construct, events, streams
from .cases.model import Case, Disruption, Disruptions
from .physics import Physics
from .state import CrewState, CrewStatus, IdleCause, Site

# The case's lists, the idle cause each kind gives and its random source.
KINDS = (("crane_breakdowns", IdleCause.CRANE_BREAKDOWN, streams.CRANE_BREAKDOWN),
         ("late_deliveries", IdleCause.LATE_DELIVERY, streams.LATE_DELIVERY),
         ("absences", IdleCause.ABSENCE, streams.ABSENCE),
         ("weather_stops", IdleCause.WEATHER, streams.WEATHER))
KIND_NAMES = {cause: cause.name.lower() for _, cause, _ in KINDS}
# The kinds as the event log names them (``disruption_*`` events' detail), in the case's order.
KIND_ORDER = tuple(KIND_NAMES[cause] for _, cause, _ in KINDS)
# their columns in episode rows and comparisons (``struck``): how many struck, and for how long
STRUCK_FIELDS = tuple(f"{kind}_{what}" for kind in KIND_ORDER for what in ("count", "downtime_s"))


def duration_gamma(rng: np.random.Generator, mean_s: float, sd_s: float | None) -> float:
    """One random duration: gamma with mean ``mean_s`` and standard deviation ``sd_s``.

    Shape k = (mean / sd)^2 and scale theta = sd^2 / mean, so k * theta = mean and
    k * theta^2 = sd^2; positive, skewed to the right like repair times. sd None or 0: the
    mean itself, and nothing is drawn.
    """
    if not sd_s:
        return float(mean_s)
    return float(rng.gamma((mean_s / sd_s) ** 2, sd_s * sd_s / mean_s))


def scheduled_windows(entry: Disruption, horizon_s: float) -> list[tuple[float, float]]:
    """A scheduled entry's windows [at, at + duration) starting before ``horizon_s``, every
    ``every_s`` if it repeats."""
    out, start = [], entry.at_s
    while start < horizon_s:
        out.append((start, start + entry.duration_s))
        if entry.every_s is None:
            break
        start += entry.every_s
    return out


def random_windows(rng: np.random.Generator, entry: Disruption, from_s: float,
                   horizon_s: float) -> list[tuple[float, float]]:
    """A random entry's windows from ``from_s`` on: a gap Exp(mean_interval_s), then a
    duration (``duration_s``, or ``duration_gamma``), then the next gap from its end; until a
    start at or past ``horizon_s``. Draws alternate gap, duration, gap, ... from ``rng``."""
    out, t = [], from_s
    while True:
        t += rng.exponential(entry.mean_interval_s)
        if t >= horizon_s:
            return out
        if entry.duration_s is not None:
            length = entry.duration_s
        else:
            length = duration_gamma(rng, entry.duration_mean_s, entry.duration_sd_s)
        out.append((t, t + length))
        t += length


def active(windows, time_s: float) -> bool:
    """Whether ``time_s`` lies in one of the windows [start, end)."""
    for a, b in windows:  # a plain loop: every entry's windows are looked at every second
        if a <= time_s < b:
            return True
    return False


@dataclass(frozen=True)
class Now:
    """What is disrupted during the second that starts now (``Site.disrupted``)."""

    crane_down: bool = False  # broken down (not the weather)
    weather: bool = False
    late: frozenset = frozenset()  # storages whose delivery is late
    absent: frozenset = frozenset()  # crews away from the plane

    def crane_stopped(self) -> bool:
        return self.crane_down or self.weather

    def __bool__(self) -> bool:
        return self.crane_down or self.weather or bool(self.late) or bool(self.absent)


@dataclass
class Entry:
    """One entry of the case's disruptions and the windows it was given."""

    kind: IdleCause
    source: int
    item: int  # its index in the case's list of its kind: the stream's item
    target: int  # the storage or crew index; -1 for the crane or the whole plane
    spec: Disruption
    windows: list = field(default_factory=list)


class Timeline:
    """Every disruption window of one episode, drawn when it starts (see the module doc).

    Args:
        case: the case (its ``disruptions``).
        rs: the episode's random streams.
        horizon_s: the episode's time limit: no window starts at or after it.
    """

    def __init__(self, case: Case, rs: streams.RandomStreams, horizon_s: float):
        storages = {s.id: i for i, s in enumerate(case.storages)}
        crews = {c.id: i for i, c in enumerate(case.crews)}
        self.horizon_s = horizon_s
        self.entries: list[Entry] = []
        for name, cause, source in KINDS:
            for item, spec in enumerate(getattr(case.disruptions, name)):
                target = storages[spec.storage] if cause == IdleCause.LATE_DELIVERY else \
                    crews[spec.crew] if cause == IdleCause.ABSENCE else -1
                entry = Entry(cause, source, item, target, spec)
                if spec.scheduled:
                    entry.windows = scheduled_windows(spec, horizon_s)
                else:
                    entry.windows = random_windows(rs.generator(source, item), spec, 0.0,
                                                   horizon_s)
                self.entries.append(entry)

    def resample(self, rs: streams.RandomStreams, now_s: float) -> None:
        """A sampled future (``Engine.clone(scenario=k)``): random windows not yet begun are
        drawn again from ``rs`` (its scenario's streams), from the end of the last one begun
        (or from now); windows begun and scheduled ones stay. Exponential gaps have no memory,
        so drawing the next gap from now is the same law."""
        for entry in self.entries:
            if entry.spec.scheduled:
                continue
            kept = [w for w in entry.windows if w[0] <= now_s]
            start = max([now_s] + [b for _, b in kept])
            entry.windows = kept + random_windows(rs.generator(entry.source, entry.item),
                                                  entry.spec, start, self.horizon_s)

    def at(self, time_s: float, site: Site) -> Now:
        """What is disrupted during the second starting at ``time_s``. A crew that has left
        the plane through the outlet is not absent: it has gone."""
        down = weather = False
        late, absent = set(), set()
        for entry in self.entries:
            if not active(entry.windows, time_s):
                continue
            if entry.kind == IdleCause.CRANE_BREAKDOWN:
                down = True
            elif entry.kind == IdleCause.WEATHER:
                weather = True
            elif entry.kind == IdleCause.LATE_DELIVERY:
                late.add(entry.target)
            elif site.crews[entry.target].status != CrewStatus.LEFT:
                absent.add(entry.target)
        return Now(down, weather, frozenset(late), frozenset(absent))

    def windows(self) -> list[tuple[float, float, str, int]]:
        """Every window as (start_s, end_s, kind name, target), by start."""
        return sorted((a, b, KIND_NAMES[e.kind], e.target)
                      for e in self.entries for a, b in e.windows)


def feature_size(case: Case | Site) -> int:
    """Floats ``features`` adds to the global state and to O^e: 0 for a case without
    disruptions (so models trained on one read the same sizes as before), else
    2 + n_storages + n_crews. ``case``: a case, or a site (its case)."""
    if isinstance(case, Site):
        case = case.case
    return 2 + len(case.storages) + len(case.crews) if case.disruptions else 0


def features(site: Site, out: np.ndarray) -> None:
    """What is disrupted now, into ``out`` (length ``feature_size``; each 0 or 1): crane
    broken down, weather stop, then per storage its delivery late, then per crew absent."""
    now = site.disrupted or Now()
    out[:] = 0.0
    out[0] = 1.0 if now.crane_down else 0.0
    out[1] = 1.0 if now.weather else 0.0
    n_storages = len(site.storages)
    for s in now.late:
        out[2 + s] = 1.0
    for c in now.absent:
        out[2 + n_storages + c] = 1.0


def blocking_cause(site: Site, crew: CrewState, now: Now | None) -> IdleCause:
    """The disruption that keeps the crew from working now, or NONE.

    In order: absent; a weather stop while it tasks, fetches or waits for the crane; a
    breakdown while it waits for the crane; a late delivery while it waits for a lift to its
    storage that cannot start. A crew walking is not kept from working (a weather stop lets
    crews walk), nor is one idle for another reason.
    """
    if not now or crew.status == CrewStatus.LEFT:
        return IdleCause.NONE
    if crew.index in now.absent:
        return IdleCause.ABSENCE
    status = crew.status
    if now.weather and status in (CrewStatus.TASKING, CrewStatus.FETCHING, CrewStatus.WAITING):
        return IdleCause.WEATHER
    if status == CrewStatus.WAITING:
        if now.crane_down:
            return IdleCause.CRANE_BREAKDOWN
        current = site.crane.current
        lifting = current is not None and current.kind == "material" \
            and current.storage == crew.storage
        if crew.storage >= 0 and crew.storage in now.late and not lifting:
            return IdleCause.LATE_DELIVERY
    return IdleCause.NONE


def _subject(site: Site, kind: IdleCause, target: int) -> tuple[str, str]:
    """(crew, subject) of a disruption event: the crew absent, or "" and what is disrupted."""
    if kind == IdleCause.ABSENCE:
        return site.crews[target].id, site.crews[target].id
    if kind == IdleCause.LATE_DELIVERY:
        return "", site.storages[target].id
    return "", "crane" if kind == IdleCause.CRANE_BREAKDOWN else "plane"


def _changes(before: Now, after: Now):
    """(kind, target, started) for every disruption that started or ended between the two."""
    pairs = ((IdleCause.CRANE_BREAKDOWN, {-1} if before.crane_down else set(),
              {-1} if after.crane_down else set()),
             (IdleCause.WEATHER, {-1} if before.weather else set(),
              {-1} if after.weather else set()),
             (IdleCause.LATE_DELIVERY, before.late, after.late),
             (IdleCause.ABSENCE, before.absent, after.absent))
    for kind, old, new in pairs:
        for target in sorted(old - new):
            yield kind, target, False
        for target in sorted(new - old):
            yield kind, target, True


def update(site: Site, world: Physics, log: events.EventLog, timeline: Timeline) -> bool:
    """Set ``site.disrupted`` for the second starting now; log ``disruption_start`` and
    ``disruption_end`` events; crews leave or come back; the crane takes up a request that
    a disruption held. Returns whether anything started or ended."""
    before = site.disrupted or Now()
    now = timeline.at(site.time_s, site)
    site.disrupted = now
    if now == before:
        return False
    for kind, target, started in _changes(before, now):
        crew, subject = _subject(site, kind, target)
        log.add(site.time_s, "disruption_start" if started else "disruption_end", crew,
                subject, KIND_NAMES[kind])
        if kind == IdleCause.ABSENCE:
            site.crews[target].absent = started
            if started:
                world.remove_crew(target)
            else:
                world.return_crew(target)
    crane = site.crane
    if crane.current is None and crane.queue:
        construct.start_next(site)
    return True


def refresh_causes(site: Site) -> bool:
    """Each crew's ``disruption`` (``blocking_cause``); returns whether any changed."""
    changed = False
    for crew in site.crews:
        cause = blocking_cause(site, crew, site.disrupted)
        if cause != crew.disruption:
            crew.disruption = cause
            changed = True
    return changed


def undisrupted(case: Case) -> Case:
    """The case without its ``[disruptions]``: the same seed meets the same task paces on it
    (a pace is keyed by seed and task, ``streams``), so its makespan is the floor's without
    the disruptions, and the difference is what they cost."""
    return case.model_copy(update={"disruptions": Disruptions()})


def struck(log: list[events.Event], end_s: float) -> dict[str, dict]:
    """What struck an episode, per kind (``KIND_ORDER``), read from its event log: ``count``,
    the disruptions that started, and ``downtime_s``, the seconds from each start to its end
    (or to ``end_s``, the episode's end, for one still under way), summed over what they
    struck: two crews away for an hour each are 2 absences and 7,200 s.

    Windows of one kind and subject that overlap are one disruption (the engine logs one
    start and one end); a window that would have started after the floor ended, or an
    absence of a crew that had left, never struck and is not counted.
    """
    out = {kind: {"count": 0, "downtime_s": 0.0} for kind in KIND_ORDER}
    started: dict[tuple[str, str], float] = {}
    for e in log:
        if e.kind == "disruption_start":
            started[(e.detail, e.subject)] = e.time_s
            out[e.detail]["count"] += 1
        elif e.kind == "disruption_end":
            out[e.detail]["downtime_s"] += e.time_s - started.pop((e.detail, e.subject))
    for (kind, _), start in started.items():
        out[kind]["downtime_s"] += max(0.0, end_s - start)
    return out
