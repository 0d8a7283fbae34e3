"""The masked-choice model's fit (``python -m training.research.distill fit-model`` and
``student-model``): the SB3 MaskablePPO policy of ``agents.candidates`` fitted to the labels
by cross-entropy, or built, untrained, to start as a per-type student.

It holds the fit's settings (``MODEL_FIT_DEFAULTS``, ``MODEL_FIT_HELP``), the labels as the
policy sees its decisions (``choice_rows``), a vector env of the policy's spaces alone
(``choice_venv``: the model is built without running floors), the fresh model
(``new_choice_model``), how far a scorer is from the teacher (``choice_agreement``,
``choice_regret_s``), the fit (``fit_choice_model``: Adam, early stopping on held-back label
floors) and the model's files (``save_model``). It is apart because it is the part that needs
torch and SB3 (``training.stage2``'s model); the labels and the student's fit do not.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium
import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv

from agents.candidates import (
    CANDIDATE_COLUMNS,
    LIFT_ANSWERS,
    observation_bounds,
    type_columns,
)
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.logistics import Learned
from training.research.distill_fit import soft_targets
from training.stage2 import (
    DEFAULT_CONFIG,
    Stage2Config,
    crew_types,
    new_candidate_model,
)

MODEL_FIT_DEFAULTS = {"tau_s": 300.0, "epochs": 1000, "patience": 30, "lr": 3e-3,
                      "weight_decay": 1e-4, "validation": 0.2}
MODEL_FIT_HELP = {"tau_s": "temperature of the teacher's soft choice, in seconds of makespan",
                  "epochs": "full-batch Adam steps at most",
                  "patience": "stop after this many steps without a lower validation loss",
                  "lr": "Adam's learning rate", "weight_decay": "Adam's weight decay",
                  "validation": "share of the label floors (the highest seeds) held back"}


def choice_rows(data: dict, cap: int, types: tuple[str, ...] = ()) \
        -> tuple[np.ndarray, np.ndarray]:
    """The labels as the masked-choice policy sees its decisions (``agents.candidates``): one
    flat row block per decision (V' then the features, clipped to the observation's bounds,
    padded with zeros) and the mask of real candidates. ``types``: typed rows, each ending in
    the one-hot of the decision's ``crew_type`` over this vocabulary (``CREW_TYPES``; a type
    outside it: zeros)."""

    values, features = data["values"], data["features"]
    names = tuple(data.get("feature_names", CANDIDATE_COLUMNS[1:]))
    missing = [c for c in CANDIDATE_COLUMNS[1:] if c not in names]
    if missing:
        raise ValueError(f"labels with features {', '.join(names)}: the masked-choice model "
                         f"reads {', '.join(CANDIDATE_COLUMNS[1:])} ({', '.join(missing)} "
                         "missing); fix: label with --features first or all")
    if types and "crew_type" not in data:
        raise ValueError("typed rows need the labels' crew_type; fix: label again with "
                         "`python -m training.research.distill label` (its files carry it)")
    # labels with more features (policy iteration labels all of ALL_FEATURES): the model's
    # columns, taken by name
    features = features[..., [names.index(c) for c in CANDIDATE_COLUMNS[1:]]]
    n, k = values.shape
    if k > cap:
        raise ValueError(f"labels of {k} candidates for a policy of {cap}; fix: --candidates {k}")
    width, plain = len(CANDIDATE_COLUMNS) + len(types), len(CANDIDATE_COLUMNS)
    table = np.zeros((n, cap, width), np.float32)
    mask = np.zeros((n, cap), bool)
    mask[:, :k] = ~np.isnan(values)
    table[:, :k, 0] = np.where(mask[:, :k], values, 0.0)
    table[:, :k, 1:plain] = np.where(mask[:, :k, None], features, 0.0)
    if types:
        onehot = np.stack([type_columns(str(t), tuple(types)) for t in data["crew_type"]])
        table[:, :, plain:] = onehot[:, None, :]
    low, high = observation_bounds(cap, len(types))
    flat = np.clip(table.reshape(n, -1), low, high)
    return flat * np.repeat(mask, width, axis=1), mask


def choice_venv(cap: int, types: int = 0, lift: int = 0):
    """A vector env with only the spaces of a masked-choice floor (``training.candidate_loop``;
    ``types``: that many crew-type columns a row; ``lift``: that many lift features in a lift
    block, and the two lift answers, ``agents.candidates``): enough to build the model
    without running floors."""


    low, high = observation_bounds(cap, types, lift)
    actions = cap + (LIFT_ANSWERS if lift else 0)

    class ChoiceSpaces(gymnasium.Env):
        observation_space = spaces.Box(low, high, dtype=np.float32)
        action_space = spaces.Discrete(actions)

        def reset(self, *, seed=None, options=None):
            return self.observation_space.low.copy(), {}

        def step(self, action):
            raise RuntimeError("fit-model builds the model; it plays no floor")

        def action_masks(self):
            return np.ones(actions, bool)

    return DummyVecEnv([ChoiceSpaces])


def new_choice_model(cap: int, start_rule: str, seed: int, typed: bool = False,
                     hold_choice: bool = False, lift: Learned | None = None):
    """A fresh masked-choice MaskablePPO (``training.stage2``'s, from
    ``training/configs/stage2_candidate.toml``) that starts as Eq. 9 or as ``start_rule``
    (typed: a per-type student, ``Stage2Config.typed``); ``hold_choice`` is saved with it.
    ``lift``: a learned logistics rule (``logistics.Learned``) the model's lift head starts
    as (its features, shares and weights; ``CandidateScorer.start_from_lift``)."""

    settings = Stage2Config.load(DEFAULT_CONFIG.with_name("stage2_candidate.toml")).model_dump()
    config = Stage2Config.model_validate({**settings, "candidates": cap,
                                          "start_rule": start_rule, "seed": seed,
                                          "typed": typed, "hold_choice": hold_choice})
    types = len(crew_types(config))
    if lift is None:
        return new_candidate_model(config, choice_venv(cap, types))
    head = {"lift_features": lift.features, "lift_shares": lift.shares}
    model = new_candidate_model(config, choice_venv(cap, types, len(lift.features)), head)
    model.policy.action_net.start_from_lift(lift.weights, lift.bias)
    return model


def choice_agreement(logits: np.ndarray, mask: np.ndarray, target: np.ndarray) -> float:
    """Share of decisions whose argmax (over real candidates) is the teacher's choice."""
    pick = np.argmax(np.where(mask, logits, -np.inf), axis=1)
    return float(np.mean(pick == np.argmax(target, axis=1)))


def choice_regret_s(scores: np.ndarray, mask: np.ndarray, makespan_s: np.ndarray) -> float:
    """Mean seconds of the teacher's makespan lost by taking the argmax of ``scores`` instead
    of the teacher's best candidate (0 for the teacher itself)."""
    k = makespan_s.shape[1]
    pick = np.argmax(np.where(mask, scores, -np.inf)[:, :k], axis=1)
    m = np.where(np.isnan(makespan_s), np.inf, makespan_s)
    return float(np.mean(m[np.arange(len(m)), pick] - m.min(axis=1)))


def fit_choice_model(data: dict, cap: int, start_rule: str = "", seed: int = 0,
                     settings: dict | None = None, log=print, typed: bool = False,
                     hold_choice: bool = False):
    """Fit the masked-choice policy's scorer to the teacher's soft choices by cross-entropy
    (Adam, early stopping on the label floors held back for validation: the last
    ``validation`` share of the seeds); returns the model and a report. ``typed``: typed
    rows from the labels' ``crew_type`` and a per-type term (``Stage2Config.typed``);
    ``hold_choice``: saved with the model."""

    settings = {**MODEL_FIT_DEFAULTS, **(settings or {})}
    torch.manual_seed(seed)
    model = new_choice_model(cap, start_rule, seed, typed, hold_choice)
    scorer = model.policy.action_net
    flat, mask = choice_rows(data, cap, model.policy.types)
    target = np.zeros(mask.shape)
    target[:, :data["values"].shape[1]] = soft_targets(data["makespan_s"], settings["tau_s"])
    seeds = np.asarray(data["row_seed"])
    floors = sorted(int(s) for s in set(seeds))
    held = floors[-max(1, round(settings["validation"] * len(floors))):]
    val = np.isin(seeds, held)
    if val.all():
        raise ValueError("fit-model needs labels of at least 2 seeds (one is held for "
                         "validation)")
    x, m, p = (torch.as_tensor(a) for a in (flat, mask, target.astype(np.float32)))

    def loss_and_logits(rows):
        logits = scorer(x[rows]).masked_fill(~m[rows], -1e9)
        logp = torch.log_softmax(logits, dim=1)
        return -(p[rows] * logp.masked_fill(~m[rows], 0.0)).sum(1).mean(), logits

    train_rows, val_rows = torch.as_tensor(~val), torch.as_tensor(val)
    with torch.no_grad():
        start_val = loss_and_logits(val_rows)[0]
        start_logits = scorer(x).masked_fill(~m, -1e9).numpy()
    optimizer = torch.optim.Adam(scorer.parameters(), lr=settings["lr"],
                                 weight_decay=settings["weight_decay"])
    best = (float(start_val), 0, {k: v.clone() for k, v in scorer.state_dict().items()})
    epoch = 0
    for epoch in range(1, settings["epochs"] + 1):
        optimizer.zero_grad()
        loss, _ = loss_and_logits(train_rows)
        loss.backward()
        optimizer.step()
        with torch.no_grad():
            val_loss = float(loss_and_logits(val_rows)[0])
        if val_loss < best[0] - 1e-5:
            best = (val_loss, epoch, {k: v.clone() for k, v in scorer.state_dict().items()})
        elif epoch - best[1] >= settings["patience"]:
            break
    scorer.load_state_dict(best[2])
    with torch.no_grad():
        logits = scorer(x).masked_fill(~m, -1e9).numpy()
        eq9 = np.where(mask, flat.reshape(len(flat), cap, -1)[:, :, 0], -np.inf)
    report = {"decisions": int(len(flat)), "validation_seeds": [int(s) for s in held],
              "epochs_run": epoch, "best_epoch": best[1],
              "validation_loss_start": round(float(start_val), 4),
              "validation_loss": round(best[0], 4)}
    for name, rows in (("train", ~val), ("validation", val)):
        for who, scores in (("eq9", eq9), ("start", start_logits), ("model", logits)):
            report[f"agree_{who}_teacher_{name}"] = round(
                choice_agreement(scores[rows], mask[rows], target[rows]), 3)
            report[f"regret_{who}_{name}_s"] = round(
                choice_regret_s(scores[rows], mask[rows], data["makespan_s"][rows]), 1)
    log(f"fit-model: {report['decisions']} decisions, best epoch {best[1]} of {epoch}; "
        f"validation seeds {held}: teacher agrees with Eq. 9 on "
        f"{report['agree_eq9_teacher_validation']:.0%}, with the start on "
        f"{report['agree_start_teacher_validation']:.0%}, with the model on "
        f"{report['agree_model_teacher_validation']:.0%} (loss "
        f"{report['validation_loss_start']} -> {report['validation_loss']}); the teacher's "
        f"makespan lost a decision: Eq. 9 {report['regret_eq9_validation_s']:.0f} s, start "
        f"{report['regret_start_validation_s']:.0f} s, model "
        f"{report['regret_model_validation_s']:.0f} s")
    return model, report


def save_model(model, out: Path, meta: dict, command: str) -> None:
    """The model zip and ``NAME.distill.json`` (``meta``) beside it, each written whole and
    moved into place (the zip last, so a zip always has its json)."""


    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp.zip")
    model.save(tmp)
    write_atomic(out.with_suffix(".distill.json"), json.dumps(meta, indent=1) + "\n")
    tmp.replace(out)
    print(f"{command}: wrote {out} (use it as --evaluator {out}) and "
          f"{out.with_suffix('.distill.json')}")
