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
    """A module docstring's first line as a ``--help`` description: no RST marks."""
    return " ".join(doc.strip().splitlines()[0].replace("``", "").split())


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


def non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number; fix: give e.g. "
                                         "0") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be 0 or more") from None
    return value


def positive_int(text: str) -> int:
    value = non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def add_ray_option(parser: argparse.ArgumentParser) -> None:
    """``--ray`` (a Ray started on this machine) or ``--ray ADDRESS`` (join that cluster); the
    value is None without the option, "local" with it alone (docs/ray.md)."""
    parser.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                        help="run the episodes on Ray actors: alone, a Ray started on this "
                             "machine; with HOST:PORT (or auto), that cluster's (needs "
                             "pip install -e '.[ray]')")


def write_search_settings(out, config, case, workers, ray) -> None:
    """A search's ``config.json`` in ``out`` (made here): settings, case, workers or Ray
    address, the command and the versions, written whole."""
    import json

    from cmdp_pymunk.events import write_atomic
    from cmdp_pymunk.rollout import versions

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
