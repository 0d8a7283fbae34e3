"""Resuming a search (the GA, the rule search) from its pickled checkpoint."""

from __future__ import annotations

import pickle
from pathlib import Path

from pydantic import BaseModel


def resume_state(checkpoint: Path, config: BaseModel, may_change: tuple[str, ...] =
                 ("generations",)):
    """The state pickled in ``checkpoint``, its ``config`` set to ``config``'s settings.

    A ValueError names the fix when there is no checkpoint, or when it was made with other
    settings than ``config``'s, apart from ``may_change`` (more generations: fine); a setting
    added to the config since the checkpoint was written counts at its default."""
    if not checkpoint.is_file():
        raise ValueError(f"{checkpoint}: no checkpoint to resume from; fix: drop --resume "
                         "or give the folder of an earlier run")
    state = pickle.loads(checkpoint.read_bytes())
    settings = config.model_dump()
    defaults = {k: f.default for k, f in type(config).model_fields.items()}
    changed = sorted(k for k in settings if k not in may_change
                     and state.config.get(k, defaults[k]) != settings[k])
    if changed:
        raise ValueError(f"{checkpoint}: made with other settings ({', '.join(changed)}); "
                         "fix: resume with the same config, or start a new --out")
    state.config = settings
    return state
