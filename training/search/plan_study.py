"""A plan search's Optuna study (``training.search.plan_search``): its storage in the run folder
(``STUDY_FILE``, ``study_storage``: Optuna's journal file), the study opened or resumed with
its pruner and the settings it keeps (``_study``), and the sampler that picks the plans
(``make_sampler``).

Apart from the search because it is everything Optuna is told before the first trial: the
search asks and tells trials, and the outputs read the study back (``plan_outputs.trial_rows``),
through this module alone. Optuna is imported inside the functions, so the package imports
without it (``cmdp-plan`` says how to install it).
"""

from __future__ import annotations

from pathlib import Path

from .plan_config import PlanConfig

STUDY_FILE = "plan.journal"


def study_storage(out: Path):
    """The study's storage in the run folder: Optuna's journal file (``STUDY_FILE``)."""
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    return JournalStorage(JournalFileBackend(str(out / STUDY_FILE)))


def _study(out: Path, config: PlanConfig, resume: bool, screened: int = 0):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    db = out / STUDY_FILE
    if db.exists() and not resume:
        raise ValueError(f"{out} already holds a plan search ({db.name}); fix: add --resume "
                         "to continue it, or give another --out")
    if resume and not db.exists():
        raise ValueError(f"--resume: {out} holds no plan search ({db.name}); fix: start one "
                         "without --resume")
    sampler = make_sampler(config, screened)
    if config.objective == "pareto":
        pruner, directions = optuna.pruners.NopPruner(), ["minimize", "minimize"]
    else:
        pruner = optuna.pruners.SuccessiveHalvingPruner(
            min_resource=config.min_seeds, reduction_factor=config.reduction_factor)
        directions = ["minimize"]
    study = optuna.create_study(storage=study_storage(out), study_name="plan",
                                directions=directions, sampler=sampler, pruner=pruner,
                                load_if_exists=True)
    kept = study.user_attrs.get("config")
    if kept is None:
        study.set_user_attr("config", config.fingerprint())
    elif kept != config.fingerprint():
        now = config.fingerprint()
        changed = sorted(k for k in kept.keys() | now.keys() if kept.get(k) != now.get(k))
        raise ValueError(f"--resume: {out} was searched with other settings ({', '.join(changed)}"
                         "); fix: resume with the same settings (only --trials may grow), or "
                         "start a new search in another --out")
    return study


def make_sampler(config: PlanConfig, screened: int = 0):
    """The Optuna sampler of ``config.sampler_name``, seeded with ``config.seed``:
    ``tpe-joint`` is ``TPESampler(multivariate=True, group=True)``, one Parzen estimator over
    every lever at once, so a plan good because two levers moved together (one more crew of
    each of two types) is sampled again as a pair. It is what Optuna 5.0's ``TPESampler()``
    does for one objective (``multivariate=None`` means True there), so every search before
    ``--sampler`` was already joint; ``group`` changes nothing while every plan sets every
    lever, and says so for ``pareto``, where ``multivariate`` would default to False.
    ``tpe-independent``: ``multivariate=False``, one estimator per lever. Both start with
    ``config.startup_trials`` random plans and read the trials' constraints. ``nsga2``:
    NSGA-II (constrained domination), a population of
    ``max(4, batch)``; ``random``: Optuna's RandomSampler, the baseline a model must beat.
    ``screened``: the screen's plans, tried before TPE's random start-up trials (so TPE still
    explores ``startup_trials`` random plans before it models them)."""
    import warnings

    import optuna

    name = config.sampler_name
    if name == "nsga2":
        return optuna.samplers.NSGAIISampler(seed=config.seed,
                                             population_size=max(4, config.batch))
    if name == "random":
        return optuna.samplers.RandomSampler(seed=config.seed)
    if name == "tpe-independent":
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=False,
                                          n_startup_trials=config.startup_trials + screened)
    with warnings.catch_warnings():
        # group is experimental in Optuna 5.0 (ExperimentalWarning); every plan sets every
        # lever, so the group is the whole space and the option only states that intent
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=True, group=True,
                                          n_startup_trials=config.startup_trials + screened)
