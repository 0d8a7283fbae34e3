"""The masked-choice policy that starts as Eq. 9 (issue 17, item 3), for sb3-contrib's
MaskablePPO.

Each candidate row (``agents.candidates.CANDIDATE_COLUMNS``) gets the logit
``heuristic_scale * V' + l(row) + r(row)``, with ``l`` linear and ``r`` a small network, both
shared by every row (so it reads any number of candidates, and one model can serve floors of
any size) and both zero at the start (or ``l`` holding a searched rule's weights).
Untrained, the logits are Eq. 9's values scaled: the argmax is Eq. 9's choice, and sampling
prefers it more strongly the larger ``heuristic_scale``. The critic is an MLP over
all rows. Everything else is ``MaskableActorCriticPolicy``'s.

A typed policy (``types``: the crew-type vocabulary, ``agents.candidates.CREW_TYPES``) reads
rows that end in a one-hot of the deciding crew's type and adds a per-type linear term
``onehot . (W @ row)`` over the other columns, zero at the start or holding a per-type
student's weights (``CandidateScorer.start_from_student``): untrained, it then chooses as the
student (``agents.student``) does. ``types`` and ``hold_choice`` (hold a choice as the
student does; read by ``agents.candidates.CandidateModelEvaluator``) are constructor
parameters saved with the model, so ``MaskablePPO.load`` rebuilds the same policy.

A policy with a lift head (``lift_features``, issue 42 item 6: the high level decides
logistics too) answers a second question with the same forward pass: whether a fetching crew
asks for the next crane lift now (``cmdp_pymunk.logistics.Logistics.lift_now``). Its
observation ends in a lift block (the lift features of ``logistics.Learned``'s names, then the
crew type's one-hot) and its action has two more answers after the candidate rows: "let the
stock run on" (logit 0) and "lift now" (logit ``b + w . phi + onehot . (W @ phi)``, a linear
term and a per-type one over the lift features, ``CandidateScorer.start_from_lift``). A target
question masks the two answers, a lift question masks the rows (``agents.lift``). "Run on"
comes first, so a logit of exactly 0 says no, as ``logistics.linear_lift``'s ``> 0``.
"""

from __future__ import annotations

import torch
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from torch import nn


class CandidateScorer(nn.Module):
    """Rows in, one logit each: ``scale * row[0] + linear(row) + r(row)``: a linear term and
    a small network, both zero at the start (``linear`` can hold a searched rule's weights:
    ``start_from_rule``).

    With ``types`` > 0 the last ``types`` of the ``columns`` are the crew type's one-hot and
    the logit adds ``onehot . (W @ row[:-types])``, a linear term per crew type over the
    other columns (V' and the features), zero at the start (``start_from_student``); the
    linear term and the network read every column, the type's too.

    With ``lift`` > 0 the flat input ends in a lift block (``lift`` features, then the
    ``types`` one-hot) and two logits follow the rows': 0 ("run on") and the lift-now logit
    (see the module doc), zero at the start (``start_from_lift``)."""

    def __init__(self, columns: int, scale: float, hidden: int = 64, types: int = 0,
                 lift: int = 0):
        super().__init__()
        if not 0 <= types < columns - 1:
            raise ValueError(f"{types} crew-type columns in rows of {columns}: a row needs V' "
                             "and at least one feature besides them")
        self.columns, self.scale, self.types = columns, scale, types
        self.linear = nn.Linear(columns, 1, bias=False)
        self.residual = nn.Sequential(nn.Linear(columns, hidden), nn.Tanh(),
                                      nn.Linear(hidden, 1))
        nn.init.zeros_(self.linear.weight)
        nn.init.zeros_(self.residual[-1].weight)
        nn.init.zeros_(self.residual[-1].bias)
        if types:  # made only when typed: an untyped scorer keeps its old parameters
            self.per_type = nn.Linear(columns - types, types, bias=False)
            nn.init.zeros_(self.per_type.weight)
        self.lift = lift
        if lift:  # made only with a lift head: a model without one keeps its parameters
            self.lift_linear = nn.Linear(lift, 1)
            nn.init.zeros_(self.lift_linear.weight)
            nn.init.zeros_(self.lift_linear.bias)
            if types:
                self.lift_per_type = nn.Linear(lift, types, bias=False)
                nn.init.zeros_(self.lift_per_type.weight)

    def forward(self, flat: torch.Tensor) -> torch.Tensor:
        if not self.lift:
            return self.target_logits(flat)
        block = flat[:, -(self.lift + self.types):]
        phi, onehot = block[:, :self.lift], block[:, self.lift:]
        now = self.lift_linear(phi).squeeze(-1)
        if self.types:
            now = now + (onehot * self.lift_per_type(phi)).sum(-1)
        answers = torch.stack([torch.zeros_like(now), now], dim=-1)  # run on, lift now
        return torch.cat([self.target_logits(flat[:, :-(self.lift + self.types)]), answers],
                         dim=-1)

    def target_logits(self, flat: torch.Tensor) -> torch.Tensor:
        """The candidate rows' logits (the rows part of the flat input)."""
        rows = flat.reshape(flat.shape[0], -1, self.columns)
        logits = (self.scale * rows[..., 0] + self.linear(rows).squeeze(-1)
                  + self.residual(rows).squeeze(-1))
        if self.types:
            plain, onehot = rows[..., :-self.types], rows[..., -self.types:]
            logits = logits + (onehot * self.per_type(plain)).sum(-1)
        return logits

    @property
    def features(self) -> int:
        """How many features follow V' in a row (the type columns not counted)."""
        return self.columns - 1 - self.types

    def start_from_rule(self, weights) -> None:
        """Logits ``scale * (V' + w . phi)``: the extended Eq. 9 of ``training.search.rule``
        (``weights``: one per feature, the columns after V'), so the untrained policy's
        argmax is that rule's choice."""
        if len(weights) != self.features:
            raise ValueError(f"{len(weights)} rule weights for {self.features} features")
        w = torch.as_tensor([0.0, *weights, *[0.0] * self.types],
                            dtype=self.linear.weight.dtype)
        with torch.no_grad():
            self.linear.weight.copy_(self.scale * w[None])

    def start_from_student(self, weights_by_type: dict[str, list[float]],
                           vocabulary: tuple[str, ...]) -> None:
        """Per-type logits ``scale * (V' + w_type . phi)`` on a fresh scorer (its linear term
        and network zero): the student of ``agents.student``, whose ``weights`` are
        ``weights_by_type`` (one per feature, the columns after V'), so the untrained
        policy's argmax is the student's choice. ``vocabulary``: the type columns' names in
        order (``CREW_TYPES``). A type the student has no weights for keeps zeros (Eq. 9, as
        in the student); ValueError for non-zero weights of a type outside the vocabulary,
        which no row can carry."""
        vocabulary = tuple(vocabulary)
        if len(vocabulary) != self.types:
            raise ValueError(f"a vocabulary of {len(vocabulary)} crew types for a scorer of "
                             f"{self.types} type columns")
        table = torch.zeros_like(self.per_type.weight)
        for crew_type, weights in weights_by_type.items():
            w = torch.as_tensor(list(weights), dtype=table.dtype)
            if w.shape != (self.features,):
                raise ValueError(f"student weights for {crew_type!r}: {w.shape[0]} numbers "
                                 f"for {self.features} features")
            if crew_type in vocabulary:
                table[vocabulary.index(crew_type), 1:] = self.scale * w
            elif w.any():
                raise ValueError(f"student weights for crew type {crew_type!r}, outside the "
                                 f"typed model's vocabulary ({', '.join(vocabulary)}): no row "
                                 "can carry them; fix: drop that type's weights (its crews "
                                 "then choose by Eq. 9) or use the student itself")
        with torch.no_grad():
            self.per_type.weight.copy_(table)

    def start_from_lift(self, weights, bias: float) -> None:
        """The lift-now logit ``scale * (bias + w . phi)`` (its per-type term zero): the
        linear rule of ``logistics.Learned`` (``weights``: one per lift feature), so the
        untrained policy says "lift now" exactly when that rule does (its sign is the rule's;
        "run on" wins a tie of 0, as the rule's strict ``> 0``)."""
        if not self.lift:
            raise ValueError("this scorer has no lift head; fix: build it with lift features")
        if len(weights) != self.lift:
            raise ValueError(f"{len(weights)} lift weights for {self.lift} lift features")
        w = torch.as_tensor([list(weights)], dtype=torch.float64) * self.scale
        with torch.no_grad():
            self.lift_linear.weight.copy_(w)
            self.lift_linear.bias.fill_(self.scale * float(bias))
            if self.types:
                self.lift_per_type.weight.zero_()


class CandidateScorerPolicy(MaskableActorCriticPolicy):
    """MaskableActorCriticPolicy whose actor is a ``CandidateScorer`` over the flat rows.

    Args (besides MaskableActorCriticPolicy's; all saved with the model):
        columns: floats per row (with the type columns when typed).
        heuristic_scale: the scale of V' in the logits.
        residual_hidden: the residual network's width.
        types: the crew-type vocabulary of typed rows (``CREW_TYPES``); () for untyped.
        hold_choice: whether ``CandidateModelEvaluator`` holds a choice other than Eq. 9's
            until the crew reaches a target (``agents.hold``, as the student does).
        lift_features: the lift head's features (names of ``logistics.Learned``), () for a
            policy without one (it answers target questions only).
        lift_shares: the decision levels at which a fetching crew is asked, as shares of a
            crane lift (``logistics.Levels``); with ``lift_features`` only.
    """

    def __init__(self, *args, columns: int, heuristic_scale: float = 10.0,
                 residual_hidden: int = 64, types: tuple[str, ...] = (),
                 hold_choice: bool = False, lift_features: tuple[str, ...] = (),
                 lift_shares: tuple[float, ...] = (), **kwargs):
        self.columns, self.heuristic_scale = columns, heuristic_scale
        self.residual_hidden = residual_hidden
        self.types, self.hold_choice = tuple(types), bool(hold_choice)  # a saved list: a tuple
        self.lift_features, self.lift_shares = tuple(lift_features), tuple(lift_shares)
        if bool(self.lift_features) != bool(self.lift_shares):
            raise ValueError("a lift head needs both lift_features and lift_shares (the "
                             "decision levels); fix: give both, or neither")
        kwargs.setdefault("net_arch", {"pi": [], "vf": [64, 64]})
        super().__init__(*args, **kwargs)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        # the actor reads the rows themselves: no hidden layers on the pi side, so the
        # latent is the flat observation, and the scorer replaces the linear action head
        self.action_net = CandidateScorer(self.columns, self.heuristic_scale,
                                          self.residual_hidden, len(self.types),
                                          len(self.lift_features))
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1),
                                              **self.optimizer_kwargs)

    def _get_constructor_parameters(self) -> dict:
        data = super()._get_constructor_parameters()
        data.update(columns=self.columns, heuristic_scale=self.heuristic_scale,
                    residual_hidden=self.residual_hidden, types=self.types,
                    hold_choice=self.hold_choice)
        if self.lift_features:  # a policy without a lift head saves what it always did
            data.update(lift_features=self.lift_features, lift_shares=self.lift_shares)
        return data
