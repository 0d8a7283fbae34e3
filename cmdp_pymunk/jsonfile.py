"""A JSON file the project reads (a learned logistics model, a GA priority file), with the
errors every input gets: the file, what is wrong with it, and the fix."""

from __future__ import annotations

import json
from pathlib import Path


class MissingFile(FileNotFoundError, ValueError):
    """No such file: a ``FileNotFoundError``, and a ``ValueError`` as every other bad input
    (the commands report those as one clear line and exit 2)."""


def read_json(path: str | Path, what: str, fix: str):
    """The data of the JSON file ``path`` (``what`` it should be, e.g. "priority file");
    a file that is missing, unreadable or not JSON raises with the file, the cause and
    ``fix``."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissingFile(f"{path}: no such {what}; fix: {fix}") from None
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise ValueError(f"{path}: cannot read the {what} ({reason}); fix: {fix}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not a JSON file ({err.msg}, line {err.lineno}); fix: "
                         f"{fix}") from None


def require_entry(data, path: str | Path, key: str, expected, fix: str) -> None:
    """A ValueError naming the file and the entry unless ``data[key]`` is ``expected``."""
    value = data.get(key) if isinstance(data, dict) else None
    if value != expected:
        raise ValueError(f"{path}: entry {key!r} is {value!r}, not {expected!r}; fix: {fix}")


__all__ = ["MissingFile", "read_json", "require_entry"]
