"""What the command-line tools share: one-line usage errors and checked numbers.

A wrong option gets exit status 2 and one line naming the option, the value and the fix
(argparse's default prints the whole usage block first).
"""

from __future__ import annotations

import argparse
import math
import sys


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
