"""Episodes as rows of numbers: what the GA, the rule search, ``cmdp-simulate`` and
``cmdp-evaluate`` share (run machinery, ``training.runs``).

``episode_row`` sums up one finished (or stopped) episode: makespan, reaching steps, idle
steps by cause, crane waits, whether it stalled or timed out, the disruptions that struck it,
and when each task ended. ``EpisodeRunner`` holds one engine and low level per (evaluator,
navigator) pair and runs seeds on them, on the case or on the case without its disruptions
(``undisrupted=True``; ``cost_fields`` pairs the two). Where they run is
``training.runs.backends``'.
"""

from __future__ import annotations

from agents.candidates import logistics_of
from agents.models import PolicyStuck
from agents.specs import evaluator_from_spec, make_navigator
from cmdp_pymunk import disruptions
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.eventfloor import Calibration, make_floor
from cmdp_pymunk.logistics import from_spec
from cmdp_pymunk.report import disruption_cost, episode_reach_rate, episode_seed_bound
from cmdp_pymunk.rollout import Episode, run_episode
from cmdp_pymunk.schedule import finish_times
from cmdp_pymunk.state import DISRUPTION_CAUSES, DISRUPTION_IDLE_FIELDS
from cmdp_pymunk.timeuse import time_use

ROW_FIELDS = ("makespan_s", "finished", "stalled", "timed_out", "tasks_finished",
              "simulated_s", "reaching_steps", "idle_waiting_for_predecessor",
              "idle_blocked_by_task_area", "idle_no_target", "idle_steps", "crane_waits",
              "crane_wait_s", "reach_rate", "wall_s", "stall_reason",
              # crew-seconds a disruption kept crews from working (``disruptions``), by kind
              *DISRUPTION_IDLE_FIELDS)
# Appended after ROW_FIELDS in episodes.csv, so older columns keep their places: how many
# disruptions of each kind struck and their downtime (``disruptions.struck``; 0 for a case
# without), then what they cost against the same seed undisrupted (``cost_fields``; empty
# when not measured).
STRUCK_FIELDS = disruptions.STRUCK_FIELDS
COST_FIELDS = ("undisrupted_makespan_s", "disruption_delay_s", "disruption_delay_pct")
# Appended after them: the bound on the seed's own floor (``bounds.seed_lower_bound``: its drawn
# paces, loading, critical path; empty in stage 1).
SEED_BOUND_FIELDS = ("seed_bound_s",)
# Beside ROW_FIELDS, in every row (episodes.jsonl) but not in episodes.csv (a list per cell):
# the simulated second each task ended, in increasing order, for the S-curve of a comparison.
TASK_END_TIMES = "task_end_times_s"
# Beside them too: crew-seconds by crew type, phase and category (``cmdp_pymunk.timeuse``).
TIME_USE = "time_use_s"


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
        "seed_bound_s": seed_bound_s(engine),
        **{f"idle_{c.name.lower()}": sum(crew.stats.idle_steps[c] for crew in crews)
           for c in DISRUPTION_CAUSES},
        **struck_fields(engine),
        TASK_END_TIMES: task_end_times(engine),
        TIME_USE: time_use(engine.log.events, {c.id: c.type for c in crews}, len(site.tasks),
                           site.time_s),
    }


def seed_bound_s(engine: Engine) -> float | None:
    """The bound on the engine's seed's floor in seconds (``report.episode_seed_bound``)."""
    bound = episode_seed_bound(engine)
    return round(bound.seed_bound_s, 3) if bound else None


def struck_fields(engine: Engine) -> dict:
    """``STRUCK_FIELDS`` of the engine's episode: per kind, the disruptions that struck and
    their downtime in seconds (``disruptions.struck``; zeros for a case without)."""
    struck = disruptions.struck(engine.log.events, engine.site.time_s) \
        if engine.case.disruptions else {}
    return {f"{kind}_{what}": struck.get(kind, {}).get(what, 0)
            for kind in disruptions.KIND_ORDER for what in ("count", "downtime_s")}


def cost_fields(row: dict, undisrupted_row: dict | None) -> dict:
    """``COST_FIELDS`` of an episode row against the row of the same seed, evaluator and low
    level on the case without disruptions (``EpisodeRunner.run(..., undisrupted=True)``;
    None: not measured): its makespan, the delay (s) and the delay in % of it
    (``report.disruption_cost``)."""
    if undisrupted_row is None:
        return dict.fromkeys(COST_FIELDS)
    cost = disruption_cost(row["makespan_s"], undisrupted_row["makespan_s"])
    return {"undisrupted_makespan_s": cost["undisrupted_makespan_s"],
            "disruption_delay_s": cost["delay_s"], "disruption_delay_pct": cost["delay_pct"]}


def make_engine(case, evaluator, navigator_spec: str, max_time_s: float | None = None,
                position_log_every_s: float | None = None, fidelity: str = "pymunk",
                calibration: Calibration | None = None, logistics: str = "case") -> Engine:
    """The stage-2 floor as ``cmdp-simulate`` builds it: the scripted navigator lets the engine
    skip parked crews' seconds (``park_idle``); a trained navigator decides for every crew.
    ``position_log_every_s``: moving crews' positions in the event log (trajectories).
    ``fidelity``: "pymunk" (the paper's floor) or "event" (``cmdp_pymunk.eventfloor``, whose
    crews walk without a low level; ``calibration`` its fitted numbers). ``logistics``: a
    ``--logistics`` spec (``cmdp_pymunk.logistics.from_spec``; "case": the case's reorder
    point), made into a role of this engine's own; left at "case" with an evaluator that
    decides logistics too (a stage-2 model with a lift head, ``agents.lift``), that
    evaluator's role answers."""
    # under "case" an evaluator with a lift head answers (None for every other evaluator:
    # the case's reorder point)
    role = logistics_of(evaluator) if logistics == "case" else from_spec(logistics)
    return make_floor(case, fidelity, calibration, stage=2, evaluator=evaluator,
                      max_time_s=max_time_s, park_idle=navigator_spec == "scripted",
                      position_log_every_s=position_log_every_s, logistics=role)


class EpisodeRunner:
    """Engines and low levels kept per (evaluator, navigator) pair; ``run`` plays one seed.

    An evaluator is a spec (``agents.specs.evaluator_from_spec``) or an evaluator object (the GA
    passes its individuals); an object is swapped into a cached engine of the same navigator.
    ``position_log_every_s``, ``fidelity``, ``calibration``, ``logistics``: see
    ``make_engine`` (the floor the seeds run on and who asks for lifts; its calibration and
    logistics serve the case without disruptions too: the same floor). ``undisrupted=True``
    in ``run``: the same seed on the case without its disruptions (``disruptions.undisrupted``), on
    engines of its own.
    """

    def __init__(self, case, stall_s: float | None = 3600.0, max_time_s: float | None = None,
                 deterministic: bool = False, position_log_every_s: float | None = None,
                 fidelity: str = "pymunk", calibration: Calibration | None = None,
                 logistics: str = "case"):
        # a bad fidelity name or logistics spec (or a role that misfits the case) fails here
        make_floor(case, fidelity, calibration, logistics=from_spec(logistics))
        self.case = case
        self.fidelity = fidelity
        self.calibration = calibration
        self.logistics = logistics
        self.stall_s = stall_s
        self.max_time_s = max_time_s
        self.deterministic = deterministic
        self.position_log_every_s = position_log_every_s
        self._cache: dict = {}
        self._undisrupted = None  # the case without its disruptions, made when first asked
        self.playing = None  # the engine of the episode under way in ``play`` (for its time)

    def _engine(self, evaluator, navigator_spec: str, undisrupted: bool = False):
        key = (evaluator if isinstance(evaluator, str) else "<object>", navigator_spec,
               undisrupted)
        if key not in self._cache:
            case = self.case
            if undisrupted:
                if self._undisrupted is None:
                    self._undisrupted = disruptions.undisrupted(self.case)
                case = self._undisrupted
            ev = evaluator_from_spec(evaluator) if isinstance(evaluator, str) else evaluator
            engine = make_engine(case, ev, navigator_spec, self.max_time_s,
                                 self.position_log_every_s, self.fidelity, self.calibration,
                                 self.logistics)
            self._cache[key] = (engine, make_navigator(navigator_spec, engine,
                                                       self.deterministic))
        engine, navigator = self._cache[key]
        if not isinstance(evaluator, str):
            engine.evaluator = evaluator
        return engine, navigator

    def run(self, evaluator, navigator_spec: str, seed: int, undisrupted: bool = False) -> dict:
        """One seed's ``episode_row``; ``undisrupted``: on the case without disruptions."""
        engine, navigator = self._engine(evaluator, navigator_spec, undisrupted)
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
        make_engine(case, evaluator_from_spec(spec), "scripted")
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
