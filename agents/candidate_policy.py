"""The masked-choice policy that starts as Eq. 9 (issue 17, item 3), for sb3-contrib's
MaskablePPO.

Each candidate row (``agents.candidates.CANDIDATE_COLUMNS``) gets the logit
``heuristic_scale * V' + l(row) + r(row)``, with ``l`` linear and ``r`` a small network, both
shared by every row (so it reads any number of candidates, and one model can serve floors of
any size) and both zero at the start (or ``l`` holding a searched rule's weights).
Untrained, the logits are Eq. 9's values scaled: the argmax is Eq. 9's choice, and sampling
prefers it more strongly the larger ``heuristic_scale``. The critic is an MLP over
all rows. Everything else is ``MaskableActorCriticPolicy``'s.
"""

from __future__ import annotations

import torch
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from torch import nn


class CandidateScorer(nn.Module):
    """Rows in, one logit each: ``scale * row[0] + linear(row) + r(row)``: a linear term and
    a small network, both zero at the start (``linear`` can hold a searched rule's weights:
    ``start_from_rule``)."""

    def __init__(self, columns: int, scale: float, hidden: int = 64):
        super().__init__()
        self.columns, self.scale = columns, scale
        self.linear = nn.Linear(columns, 1, bias=False)
        self.residual = nn.Sequential(nn.Linear(columns, hidden), nn.Tanh(),
                                      nn.Linear(hidden, 1))
        nn.init.zeros_(self.linear.weight)
        nn.init.zeros_(self.residual[-1].weight)
        nn.init.zeros_(self.residual[-1].bias)

    def forward(self, flat: torch.Tensor) -> torch.Tensor:
        rows = flat.reshape(flat.shape[0], -1, self.columns)
        return (self.scale * rows[..., 0] + self.linear(rows).squeeze(-1)
                + self.residual(rows).squeeze(-1))

    def start_from_rule(self, weights) -> None:
        """Logits ``scale * (V' + w . phi)``: the extended Eq. 9 of ``training.search.rule``
        (``weights``: one per feature, the columns after V'), so the untrained policy's
        argmax is that rule's choice."""
        w = torch.as_tensor([0.0, *weights], dtype=self.linear.weight.dtype)
        if w.shape[0] != self.columns:
            raise ValueError(f"{len(weights)} rule weights for {self.columns - 1} features")
        with torch.no_grad():
            self.linear.weight.copy_(self.scale * w[None])


class CandidateScorerPolicy(MaskableActorCriticPolicy):
    """MaskableActorCriticPolicy whose actor is a ``CandidateScorer`` over the flat rows."""

    def __init__(self, *args, columns: int, heuristic_scale: float = 10.0,
                 residual_hidden: int = 64, **kwargs):
        self.columns, self.heuristic_scale = columns, heuristic_scale
        self.residual_hidden = residual_hidden
        kwargs.setdefault("net_arch", {"pi": [], "vf": [64, 64]})
        super().__init__(*args, **kwargs)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        # the actor reads the rows themselves: no hidden layers on the pi side, so the
        # latent is the flat observation, and the scorer replaces the linear action head
        self.action_net = CandidateScorer(self.columns, self.heuristic_scale,
                                          self.residual_hidden)
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1),
                                              **self.optimizer_kwargs)

    def _get_constructor_parameters(self) -> dict:
        data = super()._get_constructor_parameters()
        data.update(columns=self.columns, heuristic_scale=self.heuristic_scale,
                    residual_hidden=self.residual_hidden)
        return data
