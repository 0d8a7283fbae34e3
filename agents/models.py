"""Trained Stable-Baselines3 models in the places the scripted policies take.

``PolicyNavigator``: a stage-1 reaching policy (observation Box(115) or Box(119), action
MultiDiscrete([4, 3, 3])) as the low level. ``ModelEvaluator``: a stage-2 evaluation policy
(observation O^e, action Box(2), the desired position) as the target evaluator, through Eq. 4.
Both load on the CPU. The navigator samples its actions unless asked for argmax
(``deterministic=True``, which stops with :class:`PolicyStuck` when a crew gets nowhere); the
evaluator acts deterministically.

``LeanActor``: the actor half of an SB3 MLP policy (its layers' weights copied out) evaluated in
numpy. One SB3 forward on a few rows costs about 0.4 ms here, nearly all of it per-call overhead
(tensor conversion, distribution objects); the same arithmetic in numpy costs tens of
microseconds. Its actions are SB3's own: argmax per sub-action (``MultiDiscrete``) or the
Gaussian mean clipped to the action space (``Box``) when deterministic; sampled from the same
distribution with a ``numpy.random.Generator`` otherwise (not torch's generator, so the samples
for a seed differ from ``model.predict``'s, but a seed always gives the same samples).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cmdp_pymunk.disruptions import feature_size as disruption_feature_size
from cmdp_pymunk.evaluate import DesiredPositionEvaluator, desired_position_values
from cmdp_pymunk.move import STAND_STILL
from cmdp_pymunk.observe import (
    evaluation_bounds,
    evaluation_observation,
    evaluation_size,
    ray_model,
)

ACTIVATIONS = {"Tanh": np.tanh, "ReLU": lambda x: np.maximum(x, 0.0, out=x)}


def load_model(path: str | Path, algorithm=None, what: str = "PPO model",
               fix: str = "give a .zip written by model.save()"):
    """An SB3 zip (``algorithm``'s ``load``, default PPO) on the CPU with one torch thread;
    a ValueError naming the file and ``fix`` for anything it cannot load."""
    import torch
    from stable_baselines3 import PPO

    # Inference on a few rows a step: one thread is fastest, and the default (one per core)
    # made two simulations side by side fight over the cores (156 against 2,400 x real time
    # per episode here).
    torch.set_num_threads(1)

    try:
        return (algorithm or PPO).load(str(path), device="cpu")
    except Exception as err:  # SB3 raises many kinds for a file that is not its zip
        raise ValueError(f"{path}: cannot load a stable-baselines3 {what} ({err}); "
                         f"fix: {fix}") from None


def _check_shape(model, expected: int, path, what: str) -> None:
    shape = model.observation_space.shape
    if shape != (expected,):
        raise ValueError(f"{path}: the model observes {shape}, but {what} needs ({expected},); "
                         "fix: use a model trained on this case and stage")


class LeanActor:
    """An SB3 ``MlpPolicy`` actor in numpy: ``act(obs_batch, deterministic, rng)``.

    Supports what our models use: a flattening features extractor over a ``Box`` observation,
    ``nn.Linear`` layers with one activation (``Tanh`` or ``ReLU``), and a ``MultiDiscrete``
    (one categorical per sub-action), ``Discrete`` or ``Box`` action (diagonal Gaussian,
    without gSDE or squashing). Anything else is refused with the reason.

    Attributes: ``layers`` (list of (W, b), float32, W of shape (in, out)), ``action_net``
    ((W, b)), ``log_std`` (Box only), ``nvec`` (sub-action sizes; Discrete: one), ``low`` and
    ``high`` (Box bounds), ``observation_size``.
    """

    def __init__(self, layers, activation: str, action_net, action_space, log_std=None):
        from gymnasium import spaces

        if activation not in ACTIVATIONS:
            raise ValueError(f"LeanActor: activation {activation!r} is not supported; "
                             f"supported: {', '.join(ACTIVATIONS)}")
        self.layers = [(np.ascontiguousarray(w, np.float32), np.asarray(b, np.float32))
                       for w, b in layers]
        self.activation = activation
        self._activate = ACTIVATIONS[activation]
        self.action_net = (np.ascontiguousarray(action_net[0], np.float32),
                           np.asarray(action_net[1], np.float32))
        self.observation_size = (self.layers[0][0] if self.layers else self.action_net[0]).shape[0]
        self.action_space = action_space
        self.gaussian = isinstance(action_space, spaces.Box)
        if self.gaussian:
            if log_std is None:
                raise ValueError("LeanActor: a Box action needs the policy's log_std")
            self.log_std = np.asarray(log_std, np.float32)
            self.std = np.exp(self.log_std)
            self.low = action_space.low.astype(np.float32)
            self.high = action_space.high.astype(np.float32)
            self.nvec = None
        elif isinstance(action_space, spaces.MultiDiscrete):
            self.nvec = [int(n) for n in np.asarray(action_space.nvec).ravel()]
        elif isinstance(action_space, spaces.Discrete):
            self.nvec = [int(action_space.n)]
        else:
            raise ValueError(f"LeanActor: action space {action_space} is not supported; "
                             "supported: Box, Discrete, MultiDiscrete")
        if self.nvec is not None:
            self._splits = np.cumsum(self.nvec)[:-1]
            # the logits of every sub-action side by side, padded to the widest with -inf (a
            # category of probability 0): one set of numpy calls samples them all
            width, starts = max(self.nvec), np.concatenate([[0], self._splits])
            self._pad_index = np.array([[start + min(j, n - 1) for j in range(width)]
                                        for start, n in zip(starts, self.nvec, strict=True)])
            self._pad_mask = np.array([[j < n for j in range(width)] for n in self.nvec])
            self._last = np.array(self.nvec) - 1

    # -- loading --------------------------------------------------------------------------------

    @classmethod
    def from_sb3(cls, model) -> LeanActor:
        """Copy the actor's current weights out of an SB3 model (or its ``policy``)."""
        from stable_baselines3.common.torch_layers import FlattenExtractor
        from torch import nn

        policy = getattr(model, "policy", model)
        why = None
        if getattr(policy, "use_sde", False):
            why = "gSDE exploration"
        elif getattr(policy, "squash_output", False):
            why = "squashed outputs"
        elif not isinstance(policy.pi_features_extractor, FlattenExtractor) and \
                not hasattr(policy.pi_features_extractor, "actor_size"):
            why = f"the features extractor {type(policy.pi_features_extractor).__name__}"
        elif len(policy.observation_space.shape) != 1:
            why = f"the observation shape {policy.observation_space.shape}"
        if why is not None:
            raise ValueError(f"LeanActor: {why} is not supported; fix: use model.predict "
                             "for this model")
        layers, activation = [], None
        for module in policy.mlp_extractor.policy_net:
            if isinstance(module, nn.Linear):
                layers.append((_numpy(module.weight).T, _numpy(module.bias)))
            elif activation in (None, type(module).__name__):
                activation = type(module).__name__
            else:
                raise ValueError(f"LeanActor: mixed activations ({activation}, "
                                 f"{type(module).__name__}) are not supported")
        # a centralized critic's actor (agents.central_critic.ActorView) reads the head of the
        # observation only: keep the first layer's rows for it, the rest only ever met zeros
        actor_size = getattr(policy.pi_features_extractor, "actor_size", None)
        if actor_size is not None and layers:
            layers[0] = (layers[0][0][:actor_size], layers[0][1])
        action_net = (_numpy(policy.action_net.weight).T, _numpy(policy.action_net.bias))
        log_std = _numpy(policy.log_std) if hasattr(policy, "log_std") else None
        return cls(layers, activation or "Tanh", action_net, policy.action_space, log_std)

    @classmethod
    def from_zip(cls, path: str | Path) -> LeanActor:
        """Load an SB3 PPO zip (``model.save()``) and copy its actor out."""
        return cls.from_sb3(load_model(path))

    # -- acting ---------------------------------------------------------------------------------

    def _forward(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, np.float32)
        for w, b in self.layers:
            x = self._activate(x @ w + b)
        return x @ self.action_net[0] + self.action_net[1]

    def distribution(self, obs: np.ndarray) -> np.ndarray:
        """The action distribution's parameters for a batch (n, obs) of observations:
        categorical: the logits, normalised per sub-action (log-probabilities, as torch's
        ``Categorical.logits``), side by side, (n, sum(nvec)); Gaussian: the mean (n, dim)
        (the standard deviation is ``std``, the same for every row)."""
        out = self._forward(obs)
        if self.gaussian:
            return out
        parts = np.split(out, self._splits, axis=1)
        return np.concatenate([p - _logsumexp(p) for p in parts], axis=1)

    def act(self, obs: np.ndarray, deterministic: bool = True,
            rng: np.random.Generator | None = None) -> np.ndarray:
        """Actions for a batch (n, obs) of observations, as ``model.predict`` returns them:
        (n, len(nvec)) int64 for categorical actions, (n, dim) float32 clipped to the bounds
        for Gaussian ones. Sampling (``deterministic=False``) draws from ``rng``: one
        ``standard_normal`` (Gaussian) or one ``random`` (categorical, (n, len(nvec))) call."""
        if not deterministic and rng is None:
            raise ValueError("LeanActor.act: sampling needs a numpy Generator (rng=...)")
        out = self._forward(obs)
        if self.gaussian:
            if not deterministic:
                out = out + self.std * rng.standard_normal(out.shape).astype(np.float32)
            return np.clip(out, self.low, self.high)
        n = out.shape[0]
        if deterministic:
            actions = np.empty((n, len(self.nvec)), dtype=np.int64)
            start = 0
            for k, size in enumerate(self.nvec):
                actions[:, k] = out[:, start:start + size].argmax(axis=1)
                start += size
            return actions
        u = rng.random((n, len(self.nvec)))
        # inverse CDF: the first category whose cumulative probability passes u (the softmax's
        # normaliser moved to the other side: cumsum(e) < u * sum(e)); the padding adds
        # exp(-inf) = 0 after the last category, so no sum changes and none is picked
        logits = np.where(self._pad_mask, out[:, self._pad_index], np.float32(-np.inf))
        cum = np.exp(logits - logits.max(axis=2, keepdims=True)).cumsum(axis=2)
        picked = (cum < u[:, :, None] * cum[:, :, -1:]).sum(axis=2)
        return np.minimum(picked, self._last).astype(np.int64)


def _numpy(tensor) -> np.ndarray:
    return tensor.detach().cpu().numpy().astype(np.float32)


def _logsumexp(x: np.ndarray) -> np.ndarray:
    top = x.max(axis=1, keepdims=True)
    return top + np.log(np.exp(x - top).sum(axis=1, keepdims=True))


class PolicyStuck(RuntimeError):
    """An argmax policy whose crew has held a target for ``stuck_after_caps`` step caps
    without reaching any: it repeats a blocked move, and would until the stall guard."""


class PolicyNavigator:
    """A trained reaching policy, one set of weights shared by every crew (``LeanActor``).

    By default it samples its actions: the argmax policy can repeat the same blocked move
    forever (the committed stage-1 model did on seed 0). The samples come from a numpy
    generator seeded by ``reset(seed)`` at every episode and kept in the engine's ``memory``
    (so a clone of the floor samples on as the original would): a run is reproducible.
    ``deterministic=True`` takes the argmax and raises :class:`PolicyStuck` as soon as a crew
    has held a target for ``stuck_after_caps`` times the case's step cap
    (``reevaluate_after_steps``) without reaching one, instead of stalling for an hour.
    """

    stuck_after_caps = 3
    reads_rays = True
    MEMORY = "policy_navigator"

    def __init__(self, path: str | Path, deterministic: bool = False):
        self.path = Path(path)
        self.model = load_model(path)
        self.actor = LeanActor.from_sb3(self.model)
        self.deterministic = deterministic
        self.seed = 0

    @classmethod
    def from_model(cls, model, deterministic: bool = False) -> PolicyNavigator:
        """Wrap a live model (e.g. during training) without a file: the actor's weights as
        they are now."""
        navigator = cls.__new__(cls)
        navigator.path, navigator.model, navigator.deterministic = Path("<live>"), model, \
            deterministic
        navigator.actor = LeanActor.from_sb3(model)
        navigator.seed = 0
        return navigator

    def reset(self, seed: int) -> None:
        """A new episode: its samples come from a generator seeded with ``seed``."""
        self.seed = seed

    def bind(self, engine) -> None:
        """Check that the model reads this engine's case's reaching observation."""
        _check_shape(self.model, ray_model(engine.case).size, self.path,
                     "the reaching observation")

    def actions(self, engine, observations: list) -> list:
        """Every crew's action by crew index, from their reaching observations (in crew
        order): one batch of the moving crews' (the others stand still)."""
        crews = engine.site.crews
        movers = [c.index for c in crews if c.moving]
        out = [STAND_STILL] * len(crews)
        if movers:
            batch = np.stack([observations[i] for i in movers])
            rng = engine.memory.get(self.MEMORY)
            if rng is None:
                rng = engine.memory[self.MEMORY] = np.random.default_rng(self.seed)
            for i, act in zip(movers, self.actor.act(batch, self.deterministic,
                                                     rng).tolist(), strict=True):
                out[i] = tuple(act)
        if self.deterministic:
            check_not_stuck(engine, self.stuck_after_caps)
        return out


def check_not_stuck(engine, caps: int) -> None:
    """Raise :class:`PolicyStuck` naming the first crew of ``engine`` that has held a target
    for ``caps`` step caps without reaching one."""
    from cmdp_pymunk.decide import target_id

    site = engine.site
    limit = caps * engine.case.simulation.reevaluate_after_steps
    for crew in site.crews:
        if crew.moving and crew.scope and crew.steps_since_reach >= limit:
            x, y, _ = engine.pose(crew.index)
            targets = ", ".join(sorted(target_id(site, t) for t in crew.scope))
            raise PolicyStuck(
                f"the argmax navigator is stuck: {crew.id} has held its target(s) {targets} "
                f"for {crew.steps_since_reach} steps without reaching one (at x {x:.1f}, "
                f"y {y:.1f} m, t = {site.time_s:.0f} s); an argmax policy repeats a "
                "blocked move forever; fix: drop --deterministic (actions are sampled)")


class ModelEvaluator(DesiredPositionEvaluator):
    """A trained evaluation policy: its desired position values the targets by Eq. 4.

    The route of training (``cmdp_pymunk.adapters.decision_loop``): O^e from
    ``observe.evaluation_observation`` (clipped into the case's bounds, the crew's pose read
    from the engine), the actor's mean action, and ``evaluate.desired_position_values`` (Eq. 4
    as V_Tar). ``prepare(case)`` checks that the model reads this case's O^e.
    """

    def __init__(self, path: str | Path):
        super().__init__()
        self.path = Path(path)
        self.model = load_model(path)
        self.actor = LeanActor.from_sb3(self.model)
        self.bounds = None

    def prepare(self, case) -> None:
        size = evaluation_size(case)
        if self.actor.observation_size != size:
            extra = disruption_feature_size(case)
            why = (f" (of which {extra} say what is disrupted: the case has [disruptions], "
                   "which a model trained without them does not know)") if extra else ""
            raise ValueError(f"{self.path}: the model's actor reads {self.actor.observation_size} "
                             f"floats, but this case's evaluation observation has {size}{why}; "
                             "fix: use a stage-2 model trained on this case")
        self.bounds = evaluation_bounds(case)

    def values_for(self, engine, i: int) -> dict[int, float]:
        site = engine.site
        crew = site.crews[i]
        heading = engine.pose(i)[2]
        obs = evaluation_observation(site, crew, engine.positions[i], heading, self.bounds)
        return desired_position_values(self.actor.act(obs[None], deterministic=True)[0], crew,
                                       site)
