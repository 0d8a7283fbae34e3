"""What the command-line tools share: one-line usage errors and checked numbers.

A wrong option gets exit status 2 and one line naming the option, the value and the fix
(argparse's default prints the whole usage block first).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path


def plain(doc: str) -> str:
    """A module docstring's first paragraph (its summary, however many lines it wraps to) as a
    ``--help`` description: no RST marks."""
    return " ".join(doc.strip().split("\n\n")[0].replace("``", "").split())


class OneLineParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose errors are one line on stderr, exit status 2."""

    def error(self, message: str):
        sys.stderr.write(f"{self.prog}: {message}; see {self.prog} --help\n")
        raise SystemExit(2)


def positive_seconds(text: str) -> float:
    """An ``argparse`` type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds; fix: give a "
                                         "positive number, e.g. 3600") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive, finite number of "
                                         "seconds; fix: give e.g. 3600") from None
    return value


def _whole_number(text: str, least: int) -> int:
    """``text`` as a whole number of at least ``least``: one message for every wrong value
    (0 and -2 for a count of at least 1 get the same one), with the fix."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < least:
        raise argparse.ArgumentTypeError(f"{text!r} must be a whole number of at least "
                                         f"{least}; fix: give e.g. {max(least, 1)}") from None
    return value


def non_negative_int(text: str) -> int:
    """An ``argparse`` type: a whole number of 0 or more."""
    return _whole_number(text, 0)


def positive_int(text: str) -> int:
    """An ``argparse`` type: a whole number of 1 or more (a count: --episodes, --workers)."""
    return _whole_number(text, 1)


def add_ray_option(parser: argparse.ArgumentParser) -> None:
    """``--ray`` (a Ray started on this machine) or ``--ray ADDRESS`` (join that cluster); the
    value is None without the option, "local" with it alone (docs/ray.md)."""
    parser.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                        help="run the episodes on Ray actors: alone, a Ray started on this "
                             "machine; with HOST:PORT (or auto), that cluster's (needs "
                             "pip install -e '.[ray]')")


def add_logistics_option(parser: argparse.ArgumentParser) -> None:
    """``--logistics SPEC``: who decides when a fetching crew asks for the next lift
    (``cmdp_pymunk.logistics.from_spec``, the one parser of the specs); a bad spec exits 2 at
    parse time naming the option, the spec and the fix. The value stays the spec text (what
    the runs record and the workers receive)."""
    from cmdp_pymunk.logistics import LOGISTICS_HELP, from_spec

    def logistics_spec(text: str) -> str:
        try:
            from_spec(text, option="")
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        return text

    parser.add_argument("--logistics", type=logistics_spec, default="case", metavar="SPEC",
                        help=LOGISTICS_HELP + " (docs/levers.md)")


def write_search_settings(out, config, case, workers, ray) -> None:
    """A search's ``config.json`` in ``out`` (made here): settings, case, workers or Ray
    address, the command and the versions, written whole."""
    import json

    from cmdp_pymunk.events import write_atomic
    from cmdp_pymunk.report import versions

    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "config.json", json.dumps(
        {"config": config.model_dump(), "case": case.model_dump(mode="json"),
         "workers": workers, "ray": ray, "command": sys.argv, "versions": versions()},
        indent=2) + "\n")


def workers_label(workers, ray) -> str:
    """How a run's episodes are spread, for its first line."""
    from training.runs.backends import default_workers

    return f"Ray ({ray})" if ray else f"{workers or default_workers()} worker(s)"


@dataclass(frozen=True)
class SearchArgs:
    """A search command's options (``cmdp-ga``, ``cmdp-search-rule``)."""

    config: Path
    overrides: tuple[str, ...]
    workers: int | None
    out: Path
    resume: bool
    progress: bool
    ray: str | None = None


def parse_search_args(prog: str, doc: str, default_config: Path, default_out: Path,
                      writes: str, argv: list[str] | None = None) -> SearchArgs:
    """The options every search command has: --config, --set, --workers, --ray, --out (which
    holds ``writes``), --resume, --no-progress; ``doc``: the command's module docstring."""
    import cmdp_pymunk

    summary = doc.split("\n\n")[0].replace("``", "")  # the first paragraph, no RST marks
    p = OneLineParser(prog=prog, description=" ".join(summary.split()))
    cmdp_pymunk.add_version_flag(p)
    p.add_argument("--config", type=Path, default=default_config,
                   help="the search's settings (TOML; default: the shipped one)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a setting of the config, e.g. --set generations=4")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="worker processes for the floors, or Ray actors with --ray (default: "
                        "every core; with --ray ADDRESS, every CPU of the cluster)")
    add_ray_option(p)
    p.add_argument("--out", type=Path, default=default_out, help=f"folder for {writes}")
    p.add_argument("--resume", action="store_true", help="continue from DIR/checkpoint.pkl")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    a = p.parse_args(argv)
    return SearchArgs(a.config, tuple(a.set), a.workers, a.out, a.resume, not a.no_progress,
                      a.ray)


# the calendar's entries and the options that override them (cmdp-simulate, cmdp-evaluate)
CALENDAR_OPTIONS = {"start": "--start", "working_hours": "--working-hours",
                    "working_days": "--working-days", "holidays": "--holidays"}


def add_calendar_options(p: argparse.ArgumentParser, dated: str) -> None:
    """``--calendar FILE`` and the options that override its entries; ``dated`` says which
    outputs get dates."""
    p.add_argument("--calendar", type=Path, default=None, metavar="FILE.toml",
                   help="the working calendar: the [calendar] table of this file (a case file "
                        "or one with only that table), instead of the case's")
    p.add_argument("--start", default=None, metavar="ISO-DATETIME",
                   help="the calendar's start, e.g. 2026-01-05T08:00 (with no calendar yet: "
                        f"one with 08:00-16:00, Mon-Fri); dates in {dated}")
    p.add_argument("--working-hours", default=None, metavar="HH:MM-HH:MM",
                   help="the calendar's working hours, e.g. 07:00-15:30")
    p.add_argument("--working-days", default=None, metavar="DAYS",
                   help="the calendar's working days, e.g. Mon-Fri or Mon-Thu,Sat")
    p.add_argument("--holidays", default=None, metavar="DATES",
                   help="the calendar's holidays, e.g. 2026-01-12,2026-04-03")


def calendar_of(case, args):
    """The working calendar the options in ``args`` give (``calendar``, ``start``,
    ``working_hours``, ``working_days``, ``holidays``): the case's ``[calendar]``, or
    ``--calendar FILE``'s, with the other options replacing its entries; None without one.
    ``CaseError`` (exit 2) naming the file or option, the entry and the fix."""
    from cmdp_pymunk.cases.load import calendar_with, load_calendar

    calendar = load_calendar(args.calendar) if args.calendar is not None else case.calendar
    given = {field: getattr(args, field) for field in CALENDAR_OPTIONS}
    if any(value is not None for value in given.values()):
        calendar = calendar_with(calendar, given, "command line", CALENDAR_OPTIONS)
    return calendar


def seed_list(text: str) -> list[int]:
    """``0-19``, ``3,5,8`` or ``0-9,100-104``: whole numbers, ranges inclusive."""
    import argparse

    seeds: list[int] = []
    try:
        for part in text.split(","):
            a, sep, b = part.strip().partition("-")
            lo, hi = int(a), int(b) if sep else int(a)
            if lo < 0 or hi < lo:
                raise ValueError
            seeds.extend(range(lo, hi + 1))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of seeds; fix: give e.g. "
                                         "0-19 or 0,3,5 (whole numbers >= 0)") from None
    if len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"{text!r} names a seed twice")
    return seeds


def spec_list(text: str) -> list[str]:
    """``priority,nearest``: the names of a comma-separated list, blanks dropped."""
    return [s.strip() for s in text.split(",") if s.strip()]


def seeds_text(seeds: list[int]) -> str:
    """A list of seeds as ``seed_list`` reads it: ``0-19`` for a run, else ``3,5,8``."""
    if seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    return ",".join(map(str, seeds))
