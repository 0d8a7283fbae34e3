"""The time and disruption checks: what only the whole case shows about time.

``_time_problems`` refuses a case whose times and quantities are so large that no episode could
finish within ``simulation.max_time_s`` (one task, one crane lift, the crane's total, one
fetch, crossing the plane, the makespan lower bound of ``bounds``); ``_disruption_problems``
checks ``[disruptions]`` against the case: known storages and crews, durations and starts
within the time limit, no two absences of one crew at once.

Apart from ``case_check`` because these read the case as a schedule in seconds (the time limit,
windows, durations) rather than as a layout of entries that name each other.
"""

from __future__ import annotations

import math

from .field_problems import _did_you_mean, _Parts, _valid
from .model import Case, Disruptions, Simulation

# -- the time limit: floors under any schedule --------------------------------------------

def _time_problems(case: Case) -> list[str]:
    """Times and quantities so large that no episode could finish within the time limit.

    Each check is a floor under any schedule: one task's expected duration, one crane lift,
    the crane's total busy time, one fetch, walking across the plane, and the makespan lower
    bound (``bounds``). A run that could never finish would only stall.
    """
    from ..bounds import expected_duration_s, lower_bound

    limit = case.simulation.max_time_s
    over = f"beyond simulation.max_time_s = {limit:g} s, so no episode could finish"
    fix_limit = "or raise simulation.max_time_s"
    problems = []
    for name, value in (("lift_time_s", case.crane.lift_time_s),
                        ("assist_time_s", case.crane.assist_time_s)):
        if value >= limit:
            problems.append(f"crane: {name} = {value:g} s is {over}; fix: give the time of one "
                            f"lift in seconds (the paper's crane takes minutes) {fix_limit}")
    for i, task in enumerate(case.tasks):
        seconds = expected_duration_s(case, task)
        if seconds >= limit:
            problems.append(f'tasks[{i}] "{task.id}": its expected duration ({seconds:.4g} s '
                            f"at the crew type's mean pace) is {over}; fix: check work, the "
                            f"crew type's pace and its unit, {fix_limit}")
    crane_s = 0.0
    for name, mat in case.materials.items():
        needed = sum(t.material_quantity for t in case.tasks
                     if case.task_types[t.type].material == name)
        crane_s += math.ceil(needed / mat.crane_lift_quantity) * case.crane.lift_time_s
        for ct_name, ct in case.crew_types.items():
            carries = any(tt.crew_type == ct_name and tt.material == name
                          for tt in case.task_types.values())
            if carries and ct.carry_capacity / mat.acquire_per_min * 60.0 >= limit:
                problems.append(f"materials.{name}: acquire_per_min = {mat.acquire_per_min:g} "
                                f"fills a {ct_name} crew's load ({ct.carry_capacity:g}) in "
                                f"more than the time limit, {over}; fix: check "
                                f"acquire_per_min and carry_capacity, {fix_limit}")
    crane_s += sum(case.crane.assist_time_s for t in case.tasks
                   if case.task_types[t.type].needs_crane)
    if crane_s >= limit and not problems:
        problems.append(f"crane: its lifts and assistance add up to {crane_s:.4g} s, {over}; "
                        f"fix: check lift_time_s, assist_time_s and the materials' "
                        f"crane_lift_quantity, {fix_limit}")
    across = case.plane.width_m + case.plane.height_m
    for name, ct in case.crew_types.items():
        if across / ct.velocity_m_s >= limit:
            problems.append(f"crew_types.{name}: velocity_m_s = {ct.velocity_m_s:g} takes "
                            f"{across / ct.velocity_m_s:.4g} s to cross the plane, {over}; "
                            f"fix: give the velocity in metres per second, {fix_limit}")
    if not problems:
        bound = lower_bound(case)
        if bound.lower_bound_s >= limit:
            problems.append(f"simulation: max_time_s = {limit:g} s is below the makespan lower "
                            f"bound of {bound.lower_bound_s:.0f} s (critical path "
                            f"{' -> '.join(bound.critical_path[:4])}"
                            f"{' ...' if len(bound.critical_path) > 4 else ''}), so no episode "
                            "could finish; fix: raise max_time_s, or check the tasks' work and "
                            "the crews' paces")
    return problems


# -- disruptions: references, times, overlaps --------------------------------------------

_DISRUPTION_KINDS = {"crane_breakdowns": None, "late_deliveries": ("storage", "storages"),
                     "absences": ("crew", "crews"), "weather_stops": None}
_MAX_CHECKED_WINDOWS = 10000  # repeats of one scheduled entry checked for overlaps


def _scheduled_windows(entry, limit: float) -> list[tuple[float, float]]:
    """The windows [start, end) of a scheduled entry that start before ``limit``."""
    out, start = [], entry.at_s
    while start < limit and len(out) < _MAX_CHECKED_WINDOWS:
        out.append((start, start + entry.duration_s))
        if entry.every_s is None:
            break
        start += entry.every_s
    return out


def _disruption_problems(data: dict, case: Case | None, parts: _Parts) -> list[str]:
    """What field-by-field validation of ``[disruptions]`` cannot see: unknown storages and
    crews, durations or starts beyond the time limit, overlapping absences of one crew."""
    if case is not None:
        disruptions, simulation = case.disruptions, case.simulation
    else:
        disruptions = _valid(Disruptions, data.get("disruptions", {}))
        simulation = _valid(Simulation, data.get("simulation", {}))
    if not disruptions:
        return []
    limit = simulation.max_time_s if simulation is not None else None
    problems: list[str] = []
    absences: dict[str, list[tuple[float, float, str]]] = {}
    for kind, ref in _DISRUPTION_KINDS.items():
        for i, entry in enumerate(getattr(disruptions, kind)):
            where = f"disruptions.{kind}[{i}]"
            if ref is not None:
                field, section = ref
                name, known = getattr(entry, field), parts.names[section]
                if known is not None and name not in known:
                    problems.append(f'{where}: {field} "{name}" is not in [[{section}]]'
                                    f"{_did_you_mean(name, known)}")
            if limit is None:
                continue
            duration = "duration_s" if entry.duration_s is not None else "duration_mean_s"
            if entry.longest_s >= limit:
                problems.append(f"{where}: {duration} = {entry.longest_s:g} s is not shorter "
                                f"than simulation.max_time_s = {limit:g} s, so the floor "
                                f"could not finish; fix: shorten {duration} (seconds, not "
                                "minutes?) or raise simulation.max_time_s")
            if entry.at_s is not None and entry.at_s >= limit:
                problems.append(f"{where}: at_s = {entry.at_s:g} s is not before "
                                f"simulation.max_time_s = {limit:g} s, so it never happens; "
                                "fix: give a start within the time limit, or remove the entry")
            if entry.mean_interval_s is not None and entry.mean_interval_s >= limit:
                problems.append(f"{where}: mean_interval_s = {entry.mean_interval_s:g} s is not "
                                f"shorter than simulation.max_time_s = {limit:g} s, so it "
                                "would rarely happen at all; fix: give the mean seconds "
                                "between occurrences within the time limit, or remove it")
            if kind == "absences" and entry.scheduled and entry.longest_s < limit:
                absences.setdefault(entry.crew, []).extend(
                    (a, b, where) for a, b in _scheduled_windows(entry, limit))
    for crew, windows in absences.items():
        windows.sort()
        for (a0, b0, w0), (a1, _, w1) in zip(windows, windows[1:], strict=False):
            if a1 < b0:
                problems.append(f'{w1}: crew "{crew}" is already absent from {a0:g} s to '
                                f"{b0:g} s ({w0}), and this absence starts at {a1:g} s; fix: "
                                "start it after the other ends, or merge the two entries")
                break
    return problems
