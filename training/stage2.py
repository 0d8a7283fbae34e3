"""Stage 2 (sections 3.6.1, 4.2, 5.2): train the target-evaluation policy with SB3 PPO.

    cmdp-train stage2 [--config training/configs/stage2.toml] [--set key=value ...]
                      [--out runs/stage2] [--resume CHECKPOINT.zip]

Data flow: ``make_decision_loop`` (``cmdp_pymunk.adapters.decision_loop.DecisionLoop``, an
engine: one decision = one target evaluation; between two decisions the floor runs on with the
low level, the scripted navigator or a stage-1 model whose actions are sampled) ->
``scaffold.vec_env`` (``n_envs`` floors in ``num_cpus`` processes, each stepping its share in
one ``vec_env.FloorsVecEnv``) -> ``VecMonitor`` -> one PPO policy whose weights every crew
shares. Its action is the desired position (Box(2), Eq. 4). The formulation (one shared policy
making the team's decisions in sequence, each rewarded with the team's R_e until the next
decision) is written down in ``cmdp_pymunk/adapters/decision_loop.py``.

With ``central_critic`` (the paper's MAPPO, section 4.1) the observation is O^e followed by the
global state s, and ``agents.central_critic.CentralCriticPolicy`` lets the actor see O^e only.

Warm start (beyond the paper): behaviour cloning of the priority heuristic (Eq. 9), whose
choice is expressed as the desired position at its best target, and the critic fitted to the
heuristic episodes' discounted returns; PPO then improves on it. ``bc_episodes = 0`` starts
from scratch.

The run folder gets ``config.json`` (settings, command, versions), ``case.json``, TensorBoard
logs (``tb/``: ``cmdp/makespan_s``, ``cmdp/finished``, ``cmdp/stalled``, ``cmdp/R_e_<term>``,
``cmdp/idle_steps_<cause>`` per finished episode; ``eval/...`` on fixed seeds), ``progress.csv``,
checkpoints, ``best_model.zip`` (lowest mean evaluation makespan with every floor finished),
``final_model.zip`` and ``training_curve.png``. Ctrl-C saves ``checkpoints/interrupted.zip``.
The run itself is ``training.scaffold``'s, shared with stage 1.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Annotated, Literal, NamedTuple

import numpy as np
from pydantic import Field, Strict, model_validator

import cmdp_pymunk
from cmdp_pymunk.adapters.decision_loop import IDLE_CAUSES, DecisionLoop
from cmdp_pymunk.events import write_atomic
from cmdp_pymunk.reward import EVALUATION_TERMS

from . import scaffold
from .config import CountOrZero, Rate

DEFAULT_CONFIG = Path(__file__).with_name("configs") / "stage2.toml"


class Stage2Config(scaffold.PPOSettings):
    """Every setting of a stage-2 run: ``scaffold.PPOSettings``' (with stage 2's values in
    ``DEFAULTS``; ``total_steps`` and the evaluation's counts are decisions: a lone target is
    no decision; ``n_steps``, decisions per env copy; ``gamma``, per decision) and stage 2's
    own; the TOML config file and ``--set`` override these."""

    DEFAULTS = {"total_steps": 40_000, "n_envs": 2, "num_cpus": 1, "learning_rate": 1e-4,
                "batch_size": 128, "n_epochs": 5, "gamma": 0.995, "clip_range": 0.1,
                "ent_coef": 0.0, "bc_epochs": 60, "bc_batch_size": 256,
                "eval_every_steps": 4096, "eval_seeds": [2000, 2001, 2002, 2003],
                "checkpoint_every_steps": 4096}

    low_level: str = "scripted"  # "scripted" or a stage-1 model .zip (actions sampled)
    # the floor the decisions are played on (issue 32, item 5): "pymunk", the paper's, or
    # "event", the event floor with the case's calibration (no physics and no low level:
    # some 40 times as many decisions a second, so budgets of 100,000s of decisions fit two
    # cores); a model trained there runs on the pymunk floor (the same spaces) and is
    # fine-tuned there with start_model
    fidelity: Literal["pymunk", "event"] = "pymunk"
    stall_s: Rate = 3600.0  # truncate an episode in which no task moves on for this long
    central_critic: bool = True  # MAPPO: the critic also sees the global state
    # R_e (Eq. 5) weights for training; they replace the case's [evaluation_reward]
    idle_predecessor: float = -0.0002
    idle_area: float = -0.0002
    efficiency: float = 0.0002
    episode: float = -0.001  # per simulated second: the makespan term
    path: float = 0.0
    completion: float = 1.0
    log_std_init: float = -1.6  # the desired position's spread (std 0.2 of the plane's half)
    # warm start: behaviour cloning of the priority heuristic on this many floors (its
    # evaluation: the policy's mean action)
    bc_episodes: CountOrZero = 24
    # the action (issue 17, item 3): "desired_position" (Eq. 4, the paper's) or "candidate",
    # a masked choice among the deciding crew's `candidates` best targets by Eq. 9 with
    # sb3-contrib's MaskablePPO; its policy starts as Eq. 9 (agents/candidate_policy.py), so
    # it has no behaviour cloning (bc_episodes is not used) and no centralized critic
    action: Literal["desired_position", "candidate"] = "desired_position"
    candidates: Annotated[int, Strict(), Field(ge=2)] = 5
    heuristic_scale: Rate = 10.0  # the candidate policy's logits: this times Eq. 9's V' + r
    # the candidate policy starts as this searched rule (a student file of cmdp-search-rule,
    # one weight vector for every crew type) instead of Eq. 9; "" for Eq. 9. With typed: a
    # per-type student (training.research.distill fit --features first), one vector per type
    start_rule: str = ""
    # typed rows (candidate action only): each row also carries a one-hot of the deciding
    # crew's type (agents.candidates.CREW_TYPES; a type outside it: zeros) and the policy a
    # linear term per type, so it can start exactly as a per-type student (start_rule)
    typed: bool = False
    # hold a choice other than Eq. 9's until the crew reaches a target or the target leaves
    # its scope, as the student does (agents.hold), in training and in the saved model
    hold_choice: bool = False
    # or from this masked-choice model's weights (e.g. `python -m training.research.distill
    # fit-model`: PPO fine-tunes the distilled policy); "" for none
    start_model: str = ""
    # reward: at a floor's end, R_e's makespan term against Eq. 9's makespan on the same seed
    # (training.candidate_loop.terminal_term; candidate action only), and the training seeds
    # taken modulo seed_pool (0: any seed) so that Eq. 9 plays each seed once
    against_heuristic: bool = False
    seed_pool: CountOrZero = 0

    @model_validator(mode="after")
    def _candidate_settings(self) -> Stage2Config:
        if (self.start_rule or self.against_heuristic or self.seed_pool) \
                and self.action != "candidate":
            raise ValueError("start_rule, against_heuristic and seed_pool are for action = "
                             "\"candidate\"; fix: --set action=candidate, or drop them")
        if (self.typed or self.hold_choice) and self.action != "candidate":
            raise ValueError("typed and hold_choice are for action = \"candidate\" (the masked "
                             "choice's rows and holds); fix: --set action=candidate, or "
                             "typed=false and hold_choice=false")
        if self.start_rule and self.action != "candidate":
            raise ValueError("start_rule is for action = \"candidate\"; fix: --set "
                             "action=candidate, or drop start_rule")
        if self.start_model and (self.action != "candidate" or self.start_rule):
            raise ValueError("start_model is for action = \"candidate\" without start_rule; "
                             "fix: --set action=candidate and drop start_rule")
        if self.start_model and not Path(self.start_model).is_file():
            raise ValueError(f"start_model = {self.start_model!r}: no such file; fix: give a "
                             "masked-choice model .zip (python -m training.research.distill "
                             "fit-model)")
        if self.start_rule and not Path(self.start_rule).is_file():
            raise ValueError(f"start_rule = {self.start_rule!r}: no such file; fix: give the "
                             "rule.json of a cmdp-search-rule run (typed: also a student of "
                             "`python -m training.research.distill fit --features first`)")
        if self.action == "candidate" and self.central_critic:
            raise ValueError("action = \"candidate\" has no centralized critic (its critic reads "
                             "the candidates' rows); fix: --set central_critic=false")
        return self

    @model_validator(mode="after")
    def _low_level_exists(self) -> Stage2Config:
        if self.low_level != "scripted" and not Path(self.low_level).is_file():
            raise ValueError(f"low_level = {self.low_level!r}: no such stage-1 model; fix: give "
                             '"scripted" or the path of a stage-1 .zip')
        if self.low_level != "scripted" and self.fidelity == "event":
            raise ValueError(f"low_level = {self.low_level!r} with fidelity = \"event\": the "
                             "event floor has no low level (crews walk the shortest way); fix: "
                             "--set low_level=scripted, or fidelity=pymunk for a stage-1 model")
        return self


# -- environment -------------------------------------------------------------------------------

def training_case(config: Stage2Config):
    """The case with R_e's weights from the config."""
    case = cmdp_pymunk.load_case(config.case)
    weights = case.evaluation_reward.model_copy(update={
        k: getattr(config, k) for k in ("idle_predecessor", "idle_area", "efficiency", "episode",
                                        "path", "completion")})
    return case.model_copy(update={"evaluation_reward": weights})


def low_level_factory(spec: str):
    """``make_low_level()`` for ``decision_loop.DecisionLoop``: the scripted navigator, or a stage-1
    model sampling its actions (the floor binds it to its engine)."""
    def make():
        from agents.specs import make_navigator

        return make_navigator(spec, deterministic=False)

    return make


def make_decision_loop(config: Stage2Config, case):
    """A training decision loop (the floor as stage 2 sees it): the config's low level and stall
    guard, the global state after O^e with ``central_critic``. The scripted navigator reads
    the state, not the rays: idle crews are parked (as cmdp-simulate does; the schedules
    are the same) and no rays are cast. With ``action = "candidate"`` it is wrapped in
    ``training.candidate_loop.CandidateLoop``."""
    floor = DecisionLoop(case, low_level_factory(config.low_level), fidelity=config.fidelity,
                         stall_s=config.stall_s, park_idle=config.low_level == "scripted",
                         with_state=config.central_critic)
    if config.action == "candidate":
        from .candidate_loop import CandidateLoop

        plain = config.model_copy(update={"action": "desired_position", "start_rule": "",
                                          "start_model": "", "typed": False,
                                          "hold_choice": False})
        reference = partial(make_decision_loop, plain, case) \
            if config.against_heuristic else None
        return CandidateLoop(floor, config.candidates, reference, config.seed_pool,
                             crew_types(config), config.hold_choice)
    return floor


def make_vec_env(config: Stage2Config, case, seed: int, ray: str | None = None):
    """``n_envs`` floors stepped by ``num_cpus`` processes (``ray``: Ray actors, "local" or a
    cluster's address), each holding its share in one ``FloorsVecEnv``; floor k gets
    ``seed + k``."""
    from stable_baselines3.common.vec_env import VecMonitor

    from .vec_env import FloorsVecEnv

    venv = scaffold.vec_env([partial(make_decision_loop, config, case)] * config.n_envs,
                            config.num_cpus, vectorize=FloorsVecEnv, ray=ray)
    venv.seed(seed)
    return VecMonitor(venv, info_keywords=("makespan_s", "stalled"))


# -- warm start ----------------------------------------------------------------------------------

class Decision(NamedTuple):
    observation: np.ndarray
    action: np.ndarray
    reward: float
    info: dict


def play_floor(floor: DecisionLoop, seed: int, choose: Callable[[np.ndarray], np.ndarray]) \
        -> list[Decision]:
    """One episode of ``floor`` on ``seed``, ``choose(observation)`` making every decision;
    the last decision's info is the episode's end."""
    floor.reset(seed)
    decisions = []
    while True:
        obs = floor.observe()
        action = choose(obs)
        out = floor.decide(action)
        done = out.terminated or out.truncated
        decisions.append(Decision(obs, action, out.reward, floor.end_info() if done else {}))
        if done:
            return decisions


def heuristic_samples(config: Stage2Config, case, episodes: int, seed: int, log=print):
    """(observations, teacher actions, discounted returns) of every decision of ``episodes``
    floors driven by the priority heuristic (through Eq. 4 at its best target)."""
    floor = make_decision_loop(config, case)
    observations, actions, returns = [], [], []
    for k in range(episodes):
        played = play_floor(floor, seed + k, lambda _: floor.teacher_action())
        observations += [d.observation for d in played]
        actions += [d.action for d in played]
        g, back = 0.0, []
        for d in reversed(played):
            g = d.reward + config.gamma * g
            back.append(g)
        returns.extend(reversed(back))
        log(f"heuristic episode {k + 1}/{episodes}: {len(played)} decisions, makespan "
            f"{played[-1].info.get('makespan_s')}")
    return (np.asarray(observations, np.float32), np.asarray(actions, np.float32),
            np.asarray(returns, np.float32))


def behaviour_clone(model, observations, actions, returns, config: Stage2Config,
                    log=print) -> dict:
    """Fit the actor's mean to the teacher's actions and the critic to the returns (MSE), then
    set the action spread to ``log_std_init``. Returns the last losses and the share of
    decisions whose first choice (the target Eq. 4 values highest) is the teacher's."""
    import torch as th

    policy = model.policy
    obs_t = th.as_tensor(observations)
    act_t = th.as_tensor(actions)
    ret_t = th.as_tensor(returns)
    params = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = th.optim.Adam(params, lr=config.bc_learning_rate)
    gen = th.Generator().manual_seed(config.seed)
    n = len(obs_t)
    for _ in range(config.bc_epochs):
        order = th.randperm(n, generator=gen)
        for start in range(0, n, config.bc_batch_size):
            idx = order[start:start + config.bc_batch_size]
            features = policy.extract_features(obs_t[idx])
            if policy.share_features_extractor:
                latent_pi, latent_vf = policy.mlp_extractor(features)
            else:
                latent_pi = policy.mlp_extractor.forward_actor(features[0])
                latent_vf = policy.mlp_extractor.forward_critic(features[1])
            actor_loss = ((policy.action_net(latent_pi) - act_t[idx]) ** 2).mean()
            critic_loss = ((policy.value_net(latent_vf).squeeze(-1) - ret_t[idx]) ** 2).mean()
            optimizer.zero_grad()
            (actor_loss + config.vf_coef * critic_loss).backward()
            optimizer.step()
    with th.no_grad():
        policy.log_std.fill_(config.log_std_init)
        mean = policy.get_distribution(obs_t).distribution.mean.numpy()
    actor_size = getattr(policy.pi_features_extractor, "actor_size", observations.shape[1])
    agree = same_choice_share(observations[:, :actor_size], mean, actions)
    result = {"actor_loss": actor_loss.item(), "critic_loss": critic_loss.item(),
              "same_first_choice": agree}
    log(f"behaviour cloning: actor loss {result['actor_loss']:.4f}, critic loss "
        f"{result['critic_loss']:.3f}, same first choice as the heuristic {agree:.1%}")
    return result


def warm_start(model, config: Stage2Config, case, run: Path, log=print) -> None:
    """Behaviour cloning of the heuristic on ``bc_episodes`` floors (seeds from
    ``seed + 10000``); its losses and agreement go to ``behaviour_cloning.json``."""
    t0 = time.perf_counter()
    obs, acts, rets = heuristic_samples(config, case, config.bc_episodes,
                                        config.seed + 10_000, log=log)
    log(f"behaviour cloning: {len(obs):,} heuristic decisions from {config.bc_episodes} floors "
        f"in {time.perf_counter() - t0:.0f} s")
    result = behaviour_clone(model, obs, acts, rets, config, log)
    write_atomic(run / "behaviour_cloning.json", json.dumps({"decisions": len(obs), **result},
                                                            indent=2))


def first_choice(observation: np.ndarray, desired) -> int:
    """The target Eq. 4 values highest for ``desired`` among the targets in scope (O^e1 set),
    read from O^e itself (x/x_max, y/y_max at row columns 4-5, the scope flag at 8)."""
    from cmdp_pymunk.observe import CREW_FEATURES, TARGET_FEATURES

    rows = observation[CREW_FEATURES:].reshape(-1, TARGET_FEATURES)
    in_scope = np.flatnonzero(rows[:, 8] > 0.5)
    d = np.hypot(rows[in_scope, 4] - desired[0], rows[in_scope, 5] - desired[1])
    return int(in_scope[np.argmin(d)])


def same_choice_share(observations, desired, teacher) -> float:
    """The share of decisions (rows of O^e) where ``desired`` and ``teacher`` pick the same
    first target."""
    same = [first_choice(o, a) == first_choice(o, t)
            for o, a, t in zip(observations, desired, teacher, strict=True)]
    return float(np.mean(same)) if same else 0.0


# -- evaluation ---------------------------------------------------------------------------------

def evaluate_policy(actor, config: Stage2Config, case, seeds) -> dict:
    """Floors on fixed seeds with the policy's mean action (``actor``: a ``LeanActor`` or an
    SB3 model): makespans, how many finished, how many stalled."""
    from agents.models import LeanActor

    # the evaluation's own seeds as given, and no reference floors: only makespans are read
    config = config.model_copy(update={"against_heuristic": False, "seed_pool": 0})
    floor = make_decision_loop(config, case)
    if config.action == "candidate":
        def choose(obs):
            action, _ = actor.predict(obs[None], action_masks=floor.action_masks()[None],
                                      deterministic=True)
            return action[0]
    else:
        if not isinstance(actor, LeanActor):
            actor = LeanActor.from_sb3(actor)

        def choose(obs):
            return actor.act(obs[None, :floor.actor_size], deterministic=True)[0]
    makespans, finished, stalled, decisions = [], 0, 0, 0
    for seed in seeds:
        played = play_floor(floor, seed, choose)
        decisions += len(played)
        info = played[-1].info
        finished += info["makespan_s"] is not None
        stalled += bool(info["stalled"])
        makespans.append(info["makespan_s"] if info["makespan_s"] is not None
                         else info["time_s"])
    return {"mean_makespan_s": float(np.mean(makespans)), "finished": finished,
            "stalled": stalled, "episodes": len(seeds), "decisions": decisions}


# -- metrics ----------------------------------------------------------------------------------

def metrics_callback():
    """An SB3 callback: per finished or cut episode of the rollouts, the makespan, R_e's
    terms and the idle steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class Metrics(BaseCallback):
        def _on_rollout_start(self) -> None:
            self.ends: list[dict] = []

        def _on_step(self) -> bool:
            for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
                if done and "episode_terms" in info:
                    self.ends.append(info)
            return True

        def _on_rollout_end(self) -> None:
            if not self.ends:
                return
            done = [e for e in self.ends if e["makespan_s"] is not None]
            self.logger.record("cmdp/episodes", len(self.ends))
            self.logger.record("cmdp/finished", len(done) / len(self.ends))
            self.logger.record("cmdp/stalled", sum(bool(e["stalled"]) for e in self.ends))
            if done:
                self.logger.record("cmdp/makespan_s", float(np.mean([e["makespan_s"]
                                                                     for e in done])))
            for term in EVALUATION_TERMS:
                self.logger.record(f"cmdp/R_e_{term}", float(np.mean(
                    [e["episode_terms"][term] for e in self.ends])))
            for cause in IDLE_CAUSES:
                self.logger.record(f"cmdp/idle_steps_{cause}", float(np.mean(
                    [e["idle_steps"][cause] for e in self.ends])))

    return Metrics()


def best_makespan(result: dict) -> float | None:
    """An evaluation's rank: the lower its mean makespan the better, and only with every
    floor finished (None otherwise)."""
    if result["finished"] != result["episodes"]:
        return None
    return -result["mean_makespan_s"]


# -- main ---------------------------------------------------------------------------------------

def train(config: Stage2Config, run: Path, resume: Path | None = None, argv=None,
          progress_bar: bool = True, log=scaffold.say, ray: str | None = None) -> Path:
    """Train (or resume) a stage-2 run in ``run`` (``scaffold.train_ppo``); returns the final
    model's path. ``ray``: the floors on ``num_cpus`` Ray actors ("local": a Ray started
    here; else a cluster's address), the same decisions as in processes here."""
    from media.curves import draw_stage2_curve

    case = training_case(config)

    def new_model(venv):
        if config.action == "candidate":
            return new_candidate_model(config, venv)
        policy_kwargs = {"net_arch": list(config.net_arch), "log_std_init": config.log_std_init}
        policy = "MlpPolicy"
        if config.central_critic:
            from agents.central_critic import CentralCriticPolicy

            policy = CentralCriticPolicy
            policy_kwargs["actor_size"] = venv.get_attr("actor_size", [0])[0]
        return scaffold.new_ppo(config, policy, venv, policy_kwargs, seed=config.seed)

    evaluation = scaffold.Evaluation(
        play=lambda model: evaluate_policy(model, config, case, config.eval_seeds),
        describe=lambda result: f"mean makespan {result['mean_makespan_s']:.0f} s, "
                                f"{result['finished']}/{result['episodes']} finished",
        score=best_makespan, at_start=True)
    return scaffold.train_ppo(
        scaffold.Run(config, case, run, "decisions", resume, argv, progress_bar, log),
        make_venv=lambda: make_vec_env(config, case, config.seed, ray), new_model=new_model,
        warm_start=(lambda model: warm_start(model, config, case, run, log))
        if config.bc_episodes > 0 and config.action == "desired_position" else None,
        skip_warm_start="bc_episodes=0", metrics=metrics_callback(), evaluation=evaluation,
        draw_curve=draw_stage2_curve, algorithm=algorithm(config))


def algorithm(config: Stage2Config):
    """SB3's PPO, or sb3-contrib's MaskablePPO for the masked choice."""
    if config.action == "candidate":
        from sb3_contrib import MaskablePPO

        return MaskablePPO
    from stable_baselines3 import PPO

    return PPO


def crew_types(config: Stage2Config) -> tuple[str, ...]:
    """The crew-type vocabulary of the rows: ``CREW_TYPES`` when typed, else ()."""
    from agents.candidates import CREW_TYPES

    return CREW_TYPES if config.typed else ()


def new_candidate_model(config: Stage2Config, venv, lift: dict | None = None):
    """MaskablePPO with ``agents.candidate_policy.CandidateScorerPolicy`` (Eq. 9 untrained;
    ``net_arch`` is its critic's); typed rows and ``hold_choice`` go into the policy's saved
    parameters (an untyped, unheld policy's are as before), and a typed policy with
    ``start_rule`` starts as that per-type student. ``lift``: a lift head's
    ``lift_features`` and ``lift_shares`` (``agents.candidate_policy``; ``venv`` then has its
    spaces: ``training.research.distill.choice_venv``)."""
    from agents.candidate_policy import CandidateScorerPolicy
    from agents.candidates import CANDIDATE_COLUMNS

    types = crew_types(config)
    policy_kwargs = {"columns": len(CANDIDATE_COLUMNS) + len(types),
                     "heuristic_scale": config.heuristic_scale,
                     "net_arch": {"pi": [], "vf": list(config.net_arch)}}
    if types:
        policy_kwargs["types"] = types
    if config.hold_choice:
        policy_kwargs["hold_choice"] = True
    policy_kwargs.update(lift or {})
    model = scaffold.new_ppo(config, CandidateScorerPolicy, venv, policy_kwargs,
                             seed=config.seed, algorithm=algorithm(config))
    if config.start_rule and types:
        weights = student_weights(config.start_rule, config.candidates)
        try:
            model.policy.action_net.start_from_student(weights, types)
        except ValueError as err:
            raise ValueError(f"start_rule = {config.start_rule!r}: {err}") from None
    elif config.start_rule:
        model.policy.action_net.start_from_rule(rule_vector(config.start_rule,
                                                            config.candidates))
    if config.start_model:
        try:
            model.set_parameters(config.start_model, exact_match=True, device="cpu")
        except (RuntimeError, ValueError, KeyError) as err:
            raise ValueError(f"start_model = {config.start_model!r} does not fit this run's "
                             f"policy ({str(err).splitlines()[0]}); fix: the same candidates, "
                             "typed and net_arch as the model's (its .distill.json or "
                             "config)") from None
    return model


def rule_vector(path: str, candidates: int) -> list[float]:
    """The one weight vector of a searched rule's file (``training.search.rule``); ValueError
    naming the file and the fix for a rule with several vectors or other candidates."""
    from agents.student import StudentEvaluator

    rule = StudentEvaluator.load(path)
    check_model_features(rule, path, "start_rule", "an untyped model")
    vectors = {tuple(w) for w in rule.weights.values()}
    if len(vectors) != 1:
        raise ValueError(f"start_rule = {path!r}: {len(vectors)} weight vectors (one per crew "
                         "type); fix: give a rule of cmdp-search-rule (one for every type)")
    if rule.candidates != candidates:
        raise ValueError(f"start_rule = {path!r} re-ranks {rule.candidates} candidates, the "
                         f"policy {candidates}; fix: --set candidates={rule.candidates}")
    return list(vectors.pop())


def check_model_features(student, path: str, source: str, model: str) -> None:
    """A rule or student written into a masked-choice model must weigh the model's columns,
    ``FEATURE_NAMES`` in that order (weights are laid out by position); ValueError naming the
    file and the fix otherwise."""
    from agents.features import FEATURE_NAMES

    if student.features != FEATURE_NAMES:
        raise ValueError(f"{source} = {path!r}: a student of the features "
                         f"{', '.join(student.features)}; {model} reads "
                         f"{', '.join(FEATURE_NAMES)}, in that order; fix: give a rule or "
                         "student of these (cmdp-search-rule's default features, or `python -m "
                         "training.research.distill fit LABELS --features first`)")


def student_weights(path: str, candidates: int, source: str = "start_rule") -> \
        dict[str, list[float]]:
    """A per-type student's weights (``agents.student``'s file: one vector per crew type)
    for a typed policy of ``candidates`` rows; ValueError naming the file and the fix for a
    student of other features than the model's columns (``FEATURE_NAMES``, in that order) or
    of other candidates. ``source``: how the file was given, for the message."""
    from agents.student import StudentEvaluator

    student = StudentEvaluator.load(path)
    check_model_features(student, path, source, "a typed model")
    if student.candidates != candidates:
        raise ValueError(f"{source} = {path!r} re-ranks {student.candidates} candidates, the "
                         f"policy {candidates}; fix: --set candidates={student.candidates}")
    return {crew_type: w.tolist() for crew_type, w in student.weights.items()}
