"""The student's fit (``python -m training.research.distill fit``): per crew type a weight
vector w so that softmax(beta * (V' + w . phi)) over a decision's candidates matches the
teacher's soft choice, with an L2 penalty; every weight 0 is Eq. 9 itself (``agents.student``).

It holds the teacher's soft choice (``soft_targets``: softmax of minus the makespans over
``tau_s``), how much a decision's choice matters (``choice_weights``), the fit itself
(``fit_weights``, L-BFGS from a fixed start) and the choice of feature columns
(``select_features``). It is apart because it is numpy and scipy on label arrays
(``distill_labels.load_labels``), no floor and no torch: ``label_cv`` and ``policy_iteration``
fit with it too, and the masked-choice model's fit (``distill_model``) shares its soft targets.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

FIT_DEFAULTS = {"tau_s": 300.0, "l2": 1.0}


def soft_targets(makespan_s: np.ndarray, tau_s: float) -> np.ndarray:
    """The teacher's choice as probabilities: softmax(-(M - min M) / tau) over candidates
    (NaN-padded candidates get 0)."""
    m = np.where(np.isnan(makespan_s), np.inf, makespan_s)
    z = -(m - m.min(axis=1, keepdims=True)) / tau_s
    p = np.exp(z)
    return p / p.sum(axis=1, keepdims=True)


def choice_weights(makespan_s: np.ndarray) -> np.ndarray:
    """How much each decision's choice matters: the gap between its candidates' estimated
    makespans (max - min over the real, non-NaN candidates), divided by the mean gap of the
    rows given, so the weights average 1. A decision whose candidates all cost the same teaches
    nothing (weight 0: its soft target is flat, and fitting it only pulls the scores
    together); one where the wrong pick costs 800 s counts eight times one where it costs
    100 s. All gaps 0: all weights 0. Give it the rows of one crew type (``fit_weights``)."""
    gap = np.nanmax(makespan_s, axis=1) - np.nanmin(makespan_s, axis=1)
    mean = gap.mean() if len(gap) else 0.0
    return gap / mean if mean > 0 else np.zeros_like(gap)


FIT_WEIGHTS = ("none", "gap")  # fit_weights(weights=...): every decision alike, or by its gap


def fit_weights(data: dict, tau_s: float, l2: float,
                weights: str = "none") -> tuple[dict[str, np.ndarray], dict]:
    """Per crew type, w and beta minimising cross-entropy to the soft targets + l2 |w|^2;
    ``weights="gap"``: each decision's cross-entropy weighted by ``choice_weights`` (over the
    crew type's rows), so the fit spends itself where a choice costs seconds. L-BFGS from a
    fixed start: the same labels give the same weights."""

    if weights not in FIT_WEIGHTS:
        raise ValueError(f"fit weights {weights!r}: give one of {', '.join(FIT_WEIGHTS)}")
    out, report = {}, {}
    target = soft_targets(data["makespan_s"], tau_s)
    for crew_type in sorted(set(data["crew_type"])):
        rows = data["crew_type"] == crew_type
        v, phi, p = data["values"][rows], data["features"][rows], target[rows]
        mask = ~np.isnan(v)
        v0 = np.where(mask, v, 0.0)
        nf = phi.shape[2]
        row_weight = (choice_weights(data["makespan_s"][rows]) if weights == "gap"
                      else np.ones(len(v0)))

        def loss(x, v0=v0, phi=phi, p=p, mask=mask, row_weight=row_weight):
            beta, w = np.exp(x[0]), x[1:]
            logits = np.where(mask, beta * (v0 + phi @ w), -np.inf)
            top = logits.max(axis=1, keepdims=True)
            logp = logits - top - np.log(np.exp(logits - top).sum(axis=1, keepdims=True))
            per_row = -np.sum(p * np.where(mask, logp, 0.0), axis=1)  # padded: p = 0
            return float(row_weight @ per_row) / len(v0) + l2 * float(w @ w) / len(v0)

        x0 = np.zeros(1 + nf)
        x0[0] = np.log(5.0)  # beta: V' differences of about 0.2 give odds of about e
        res = minimize(loss, x0, method="L-BFGS-B")
        w = res.x[1:]
        base_choice = np.argmax(np.where(mask, v0, -np.inf), axis=1)
        student_choice = np.argmax(np.where(mask, v0 + phi @ w, -np.inf), axis=1)
        teacher = np.argmax(p, axis=1)
        out[str(crew_type)] = w
        report[str(crew_type)] = {
            "decisions": int(rows.sum()), "beta": round(float(np.exp(res.x[0])), 3),
            "agree_base_teacher": round(float(np.mean(base_choice == teacher)), 3),
            "agree_student_teacher": round(float(np.mean(student_choice == teacher)), 3),
            "loss_zero_weights": round(float(loss(np.r_[res.x[0], np.zeros(nf)])), 4),
            "loss": round(float(res.fun), 4)}
    return out, report


def select_features(data: dict, names: tuple[str, ...] | None) -> dict:
    """The labels with only the feature columns ``names`` (taken by name, in that order;
    None: all of them); ValueError naming the missing ones and the fix."""
    if names is None:
        return data
    have = tuple(data["feature_names"])
    missing = [n for n in names if n not in have]
    if missing:
        raise ValueError(f"--features {','.join(names)}: the labels hold {', '.join(have)} "
                         f"({', '.join(missing)} missing); fix: choose from those, or label "
                         "with --features all")
    return {**data, "features": data["features"][..., [have.index(n) for n in names]],
            "feature_names": tuple(names)}
