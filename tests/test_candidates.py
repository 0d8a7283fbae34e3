"""The masked choice over a crew's best targets (agents/candidates.py, training/candidate_loop.py,
agents/candidate_policy.py): it starts as Eq. 9, trains with MaskablePPO, and deploys."""

import json

import numpy as np
import pytest
import torch as th
from test_ga import far_start_case

from agents.candidates import CANDIDATE_COLUMNS, CREW_TYPES, CandidateView, observation_bounds
from agents.features import FEATURE_NAMES
from training import stage2
from training.runs.runner import EpisodeRunner
from training.stage2 import Stage2Config


def candidate_config(**kw):
    return Stage2Config(action="candidate", central_critic=False, n_envs=1, num_cpus=1, **kw)


def test_bounds_cover_eq9_and_the_features():
    low, high = observation_bounds(3)
    assert low.shape == (3 * len(CANDIDATE_COLUMNS),)
    assert (low[::len(CANDIDATE_COLUMNS)] == -1.0).all()  # V': down to b3 = -1
    assert (high[::len(CANDIDATE_COLUMNS)] == 1.5).all()  # up to b1 + b2 = 1.5
    assert (low.reshape(3, -1)[:, 1:] == 0).all() and (high.reshape(3, -1)[:, 1:] == 1).all()


def test_another_row_swaps_only_the_first_choice(tiny_env):
    from agents.lookahead import ranked

    view = CandidateView(3)
    env = tiny_env
    env.reset(seed=0)
    site = env.engine.site
    crew = next(c for c in site.crews if len(c.scope) > 1)
    position = env.engine.positions[crew.index]
    decision = view.rows(crew, site, position, env.engine.positions)
    targets = decision.targets
    base = decision.values(0)
    assert base == env.evaluator.values_for(env.engine, crew.index)  # Eq. 9's own values
    assert ranked(base)[0] == targets[0] and decision.mask.sum() == len(targets) >= 2
    swapped = decision.values(1)
    assert ranked(swapped)[0] == targets[1]
    assert swapped[targets[0]] == base[targets[1]] and swapped[targets[1]] == base[targets[0]]
    assert all(swapped[t] == base[t] for t in base if t not in targets[:2])


def test_row_zero_plays_eq9s_schedule():
    case = far_start_case()
    config = candidate_config()
    floor = stage2.make_decision_loop(config, case)
    played = stage2.play_floor(floor, 0, lambda obs: 0)
    heuristic = EpisodeRunner(case).run("priority", "scripted", 0)["makespan_s"]
    assert played[-1].info["makespan_s"] == heuristic


def test_row_zero_on_the_event_floor_plays_eq9s_event_schedule():
    """fidelity = "event" (issue 32, item 5): the same masked choice on the event floor."""
    from cmdp_pymunk import load_case
    from cmdp_pymunk.evaluate import PriorityEvaluator
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    config = candidate_config(fidelity="event")
    case = stage2.training_case(config)
    floor = stage2.make_decision_loop(config, case)
    assert type(floor.engine).__name__ == "EventFloor"
    played = stage2.play_floor(floor, 3, lambda obs: 0)
    plain = load_case(None)
    eq9 = EventFloor(plain, evaluator=PriorityEvaluator(), calibration=calibration_for(plain))
    eq9.reset(3)
    eq9.run()
    assert played[-1].info["makespan_s"] == eq9.makespan_s
    assert floor.engine.motion.calibration.fitted_on == eq9.motion.calibration.fitted_on != ""


def test_untrained_policy_chooses_eq9_on_recorded_states():
    # states of the event floor: the same rows (CandidateView) as the pymunk floor's, a
    # floor in a tenth of a second instead of seven
    config = candidate_config(fidelity="event")
    case = stage2.training_case(config)
    floor = stage2.make_decision_loop(config, case)
    model = stage2.new_candidate_model(config, stage2.make_vec_env(config, case, 0))
    states = []

    def record(obs):
        states.append((obs, floor.action_masks()))
        return 0

    stage2.play_floor(floor, 7, record)
    obs = np.stack([s[0] for s in states])
    masks = np.stack([s[1] for s in states])
    actions, _ = model.predict(obs, action_masks=masks, deterministic=True)
    assert len(states) > 20 and (actions == 0).all()


def test_a_policy_started_from_a_rule_scores_as_the_rule(tmp_path):
    from agents.candidate_policy import CandidateScorer

    scorer = CandidateScorer(len(CANDIDATE_COLUMNS), scale=10.0)
    weights = np.linspace(-0.5, 0.5, len(CANDIDATE_COLUMNS) - 1)
    scorer.start_from_rule(weights)
    rows = np.random.default_rng(0).uniform(0, 1, (4, 5, len(CANDIDATE_COLUMNS)))
    with th.no_grad():
        logits = scorer(th.as_tensor(rows.reshape(4, -1), dtype=th.float32)).numpy()
    expected = 10.0 * (rows[..., 0] + rows[..., 1:] @ weights)  # scale (V' + w . phi)
    assert np.allclose(logits, expected, atol=1e-5)


@pytest.mark.parametrize("override, message", [
    ({"action": "candidate"}, "central_critic=false"),
    ({"start_rule": "rule.json"}, 'action = "candidate"'),
    ({"action": "candidate", "central_critic": False, "start_rule": "nope.json"},
     "no such file"),
    ({"action": "candidate", "central_critic": False, "candidates": 1}, "candidates"),
    ({"start_model": "m.zip"}, 'action = "candidate"'),
    ({"action": "candidate", "central_critic": False, "start_model": "nope.zip"},
     "no such file"),
    ({"fidelity": "event", "low_level": __file__}, "event floor has no low level"),
    ({"fidelity": "physics"}, "fidelity"),
    ({"typed": True}, 'action = "candidate"'),
    ({"hold_choice": True}, "typed=false and hold_choice=false"),
])
def test_bad_candidate_settings_are_refused_with_their_fix(override, message):
    with pytest.raises(ValueError, match=message):
        Stage2Config(**override)


@pytest.mark.slow
def test_a_short_candidate_run_resumes_and_deploys(tmp_path):
    from sb3_contrib import MaskablePPO

    from agents.specs import evaluator_from_spec
    from cmdp_pymunk import TINY_CASE
    from training.commands.train import main

    def run(name, extra=()):
        argv = ["stage2", "--out", str(tmp_path / name), "--no-progress",
                "--set", f"case='{TINY_CASE}'", "--set", "action='candidate'",
                "--set", "central_critic=false", "--set", "n_envs=1", "--set", "gamma=1.0",
                "--set", "total_steps=32", "--set", "n_steps=16", "--set", "batch_size=16",
                "--set", "n_epochs=1", "--set", "eval_seeds=[1]",
                "--set", "eval_every_steps=32", "--set", "checkpoint_every_steps=32", *extra]
        assert main(argv) == 0
        return tmp_path / name

    folder = run("a")
    model = MaskablePPO.load(folder / "final_model.zip")
    assert model.num_timesteps >= 32 and model.gamma == 1.0
    checkpoint = sorted((folder / "checkpoints").glob("step_*.zip"))[-1]
    run("a", ["--resume", str(checkpoint), "--set", "total_steps=64"])
    assert MaskablePPO.load(folder / "final_model.zip").num_timesteps >= 64
    assert json.loads((folder / "config-1.json").read_text())["resumed_from"] == str(checkpoint)
    evaluator = evaluator_from_spec(str(folder / "final_model.zip"))
    assert type(evaluator).__name__ == "CandidateModelEvaluator"
    from cmdp_pymunk import load_case

    row = EpisodeRunner(load_case(TINY_CASE)).run(evaluator, "scripted", 0)
    assert row["finished"]


def test_terminal_term_against_the_heuristic_by_hand():
    from training.candidate_loop import terminal_term

    # R_e's makespan term -0.001 per second; Eq. 9 took 30,000 s on this seed.
    # Finished in 32,000 s: +30 at the end, so the floor's makespan part is
    # -32 + 30 = -2 = -0.001 * (32,000 - 30,000)
    assert terminal_term(-0.001, 30_000.0, 32_000.0, True, 80_000.0) == pytest.approx(30.0)
    # stalled at 5,000 s of an 80,000 s limit: counted as 160,000 s, so -5 + (30 - 155) = -130
    assert terminal_term(-0.001, 30_000.0, 5_000.0, False, 80_000.0) == pytest.approx(-125.0)


def test_returns_against_the_heuristic_cancel_the_heuristics_own_makespan():
    # Eq. 9 itself (row 0 everywhere) on a pooled seed (4 mod 3 = 1): the rewards sum to the
    # floor's R_e terms plus 0.001 x its own makespan, so the makespan part cancels
    case = far_start_case()
    floor = stage2.make_decision_loop(candidate_config(against_heuristic=True, seed_pool=3), case)
    total = floor.reset(4)
    while True:
        out = floor.decide(0)
        total += out.reward
        if out.terminated or out.truncated:
            break
    makespan = floor.engine.makespan_s
    assert out.terminated and floor.heuristic_makespan_s(1) == makespan
    terms = sum(floor.floor.terms.values())  # includes -0.001 x makespan and the completion
    assert total == pytest.approx(terms + 0.001 * makespan)
    assert terms + 0.001 * makespan == pytest.approx(terms - case.evaluation_reward.episode
                                                     * makespan)


def test_a_run_can_start_from_a_distilled_model(tmp_path):
    # PPO fine-tuning after distillation: the new model's scorer is the distilled one's
    from training.research import distill_model

    distilled = distill_model.new_choice_model(3, "", seed=0)
    with th.no_grad():
        distilled.policy.action_net.linear.weight.fill_(0.25)
    distilled.save(tmp_path / "d.zip")
    venv = distill_model.choice_venv(3)
    config = Stage2Config(action="candidate", central_critic=False, candidates=3,
                          net_arch=[128, 128], start_model=str(tmp_path / "d.zip"))
    model = stage2.new_candidate_model(config, venv)
    assert th.equal(model.policy.action_net.linear.weight,
                    distilled.policy.action_net.linear.weight)
    with pytest.raises(ValueError, match="same candidates"):
        stage2.new_candidate_model(config.model_copy(update={"candidates": 4}),
                                   distill_model.choice_venv(4))


@pytest.mark.parametrize("name", ["stage2.toml", "stage2_candidate.toml", "stage2_event.toml",
                                  "stage2_finetune.toml"])
def test_the_stage2_configs_load(name):
    """Every committed stage-2 config is valid as written (the event run's on the event floor,
    its fine-tuning on the pymunk floor, both at 5 candidates so the model carries over)."""
    config = Stage2Config.load(stage2.DEFAULT_CONFIG.with_name(name))
    if name in ("stage2_event.toml", "stage2_finetune.toml"):
        assert config.action == "candidate" and config.candidates == 5
        assert config.fidelity == ("event" if "event" in name else "pymunk")
        assert config.seed_pool == 100  # training seeds 0-99: no selection or report seed


# -- typed rows: a model that starts as a per-type student -----------------------------------------

TYPED_WIDTH = len(CANDIDATE_COLUMNS) + len(CREW_TYPES)


def one_feature(name: str, weight: float) -> list[float]:
    w = [0.0] * len(FEATURE_NAMES)
    w[FEATURE_NAMES.index(name)] = weight
    return w


# per-type vectors that prefer different rows: JCC the nearest target, HIC the farthest, GC
# the longest tail; RC all zeros and FC without weights (both Eq. 9, as in the student)
HAND_WEIGHTS = {"JCC": one_feature("nearness", 2.0), "HIC": one_feature("nearness", -2.0),
                "GC": one_feature("tail", 3.0), "RC": [0.0] * len(FEATURE_NAMES)}


def save_student(path, weights, candidates=3, features=FEATURE_NAMES):
    from agents.student import StudentEvaluator

    StudentEvaluator(weights, candidates, features).save(path, {"made_by": "a test"})
    return str(path)


def random_rows(n, cap, seed=0):
    """n decisions of cap rows: V' over its range, features in [0, 1], type columns 0."""
    rng = np.random.default_rng(seed)
    rows = np.zeros((n, cap, TYPED_WIDTH), np.float32)
    rows[..., 0] = rng.uniform(-1.0, 1.5, (n, cap))
    rows[..., 1:len(CANDIDATE_COLUMNS)] = rng.uniform(0.0, 1.0, (n, cap, len(FEATURE_NAMES)))
    return rows


def logits_of(scorer, rows):
    with th.no_grad():
        return scorer(th.as_tensor(rows.reshape(len(rows), -1))).numpy()


def test_typed_bounds_and_rows_end_in_the_crew_types_one_hot(tiny_env):
    low, high = observation_bounds(3, len(CREW_TYPES))
    assert low.shape == high.shape == (3 * TYPED_WIDTH,)
    types_low = low.reshape(3, -1)[:, len(CANDIDATE_COLUMNS):]
    types_high = high.reshape(3, -1)[:, len(CANDIDATE_COLUMNS):]
    assert (types_low == 0).all() and (types_high == 1).all()
    assert all((a == b).all() for a, b in zip(observation_bounds(3, 0), observation_bounds(3),
                                              strict=True))
    site = tiny_env.engine.site
    crew = next(c for c in site.crews if len(c.scope) > 1)
    where = (crew, site, tiny_env.engine.positions[crew.index], tiny_env.engine.positions)
    plain = CandidateView(3).rows(*where)
    # the tiny case's crew types (XC, KC, MC) are outside the paper's vocabulary: zeros, and
    # the other columns as untyped
    typed = CandidateView(3, CREW_TYPES).rows(*where).observation.reshape(3, TYPED_WIDTH)
    assert (typed[:, :len(CANDIDATE_COLUMNS)] == plain.observation.reshape(3, -1)).all()
    assert (typed[:, len(CANDIDATE_COLUMNS):] == 0).all()
    # a vocabulary that names the crew's type: its one-hot on every real row, pads all zeros
    own = CandidateView(3, ("ZZ", crew.type)).rows(*where)
    table = own.observation.reshape(3, len(CANDIDATE_COLUMNS) + 2)
    assert table[own.mask, len(CANDIDATE_COLUMNS):].tolist() == [[0.0, 1.0]] * own.mask.sum()
    assert (table[~own.mask] == 0).all()


def test_a_typed_policy_started_from_a_student_chooses_as_the_student():
    from agents.candidate_policy import CandidateScorer
    from agents.candidates import type_columns

    scorer = CandidateScorer(TYPED_WIDTH, scale=10.0, types=len(CREW_TYPES))
    scorer.start_from_student(HAND_WEIGHTS, CREW_TYPES)
    rows = random_rows(300, 5)
    eq9 = rows[..., 0].argmax(1)
    picks = {}
    for crew_type in CREW_TYPES:  # the same rows, told each type in turn
        rows[..., len(CANDIDATE_COLUMNS):] = type_columns(crew_type, CREW_TYPES)
        w = np.asarray(HAND_WEIGHTS.get(crew_type, [0.0] * len(FEATURE_NAMES)))
        student = rows[..., 0] + rows[..., 1:len(CANDIDATE_COLUMNS)] @ w  # V' + w_type . phi
        logits = logits_of(scorer, rows)
        assert np.allclose(logits, 10.0 * student, atol=1e-4)
        picks[crew_type] = logits.argmax(1)
        assert (picks[crew_type] == student.argmax(1)).all()
    # the types choose differently on the same rows; those without weights choose as Eq. 9
    assert (picks["JCC"] != picks["HIC"]).mean() > 0.5 and (picks["GC"] != eq9).mean() > 0.3
    assert (picks["RC"] == eq9).all() and (picks["FC"] == eq9).all()


def test_an_unknown_crew_type_scores_by_the_shared_terms_as_untyped():
    from agents.candidate_policy import CandidateScorer
    from agents.candidates import type_columns

    typed = CandidateScorer(TYPED_WIDTH, scale=10.0, types=len(CREW_TYPES))
    typed.start_from_student(HAND_WEIGHTS, CREW_TYPES)
    plain = CandidateScorer(len(CANDIDATE_COLUMNS), scale=10.0)
    th.manual_seed(0)
    with th.no_grad():  # shared terms that are not zero, copied onto the untyped scorer
        typed.linear.weight.normal_()
        typed.residual[-1].weight.normal_()
        plain.linear.weight.copy_(typed.linear.weight[:, :len(CANDIDATE_COLUMNS)])
        plain.residual[0].weight.copy_(typed.residual[0].weight[:, :len(CANDIDATE_COLUMNS)])
        plain.residual[0].bias.copy_(typed.residual[0].bias)
        plain.residual[-1].weight.copy_(typed.residual[-1].weight)
        plain.residual[-1].bias.copy_(typed.residual[-1].bias)
    rows = random_rows(50, 4)
    assert (type_columns("XC", CREW_TYPES) == 0).all()  # a type outside the vocabulary
    assert np.allclose(logits_of(typed, rows),
                       logits_of(plain, rows[..., :len(CANDIDATE_COLUMNS)]), atol=1e-5)
    # its student weights have no row to sit in: refused, unless they are zeros
    with pytest.raises(ValueError, match="outside the typed model's vocabulary"):
        typed.start_from_student({"XC": one_feature("tail", 1.0)}, CREW_TYPES)
    typed.start_from_student({"XC": [0.0] * len(FEATURE_NAMES)}, CREW_TYPES)


def test_a_typed_held_model_keeps_types_and_hold_through_save_and_load(tmp_path):
    from sb3_contrib import MaskablePPO

    from agents.candidates import CandidateModelEvaluator
    from training.research import distill_model

    student = save_student(tmp_path / "student.json", HAND_WEIGHTS)
    model = distill_model.new_choice_model(3, student, seed=0, typed=True, hold_choice=True)
    model.save(tmp_path / "typed.zip")
    loaded = MaskablePPO.load(tmp_path / "typed.zip", device="cpu")
    assert loaded.policy.types == CREW_TYPES and loaded.policy.hold_choice is True
    assert loaded.observation_space.shape == (3 * TYPED_WIDTH,)
    assert th.equal(loaded.policy.action_net.per_type.weight,
                    model.policy.action_net.per_type.weight)
    assert loaded.policy.action_net.per_type.weight.abs().sum() > 0
    evaluator = CandidateModelEvaluator(tmp_path / "typed.zip")
    assert evaluator.view.types == CREW_TYPES and evaluator.held is not None
    # an untyped model: no type columns, no hold, the parameters of before
    distill_model.new_choice_model(3, "", seed=0).save(tmp_path / "plain.zip")
    plain = CandidateModelEvaluator(tmp_path / "plain.zip")
    assert plain.view.types == () and plain.held is None
    assert not hasattr(plain.model.policy.action_net, "per_type")


def test_a_student_of_other_features_is_refused_with_the_fix(tmp_path, capsys):
    from agents.features import ALL_FEATURES
    from training.research import distill, distill_model

    for name, features in (("all", ALL_FEATURES), ("reordered", FEATURE_NAMES[::-1])):
        path = save_student(tmp_path / f"{name}.json", {"RC": [0.1] * len(features)},
                            features=features)
        config = candidate_config(candidates=3, typed=True, start_rule=path)
        with pytest.raises(ValueError, match=r"all.json|reordered.json") as err:
            stage2.new_candidate_model(config, distill_model.choice_venv(3, len(CREW_TYPES)))
        assert "in that order; fix: give a rule or student of these" in str(err.value)
        assert "--features first" in str(err.value)
        # untyped: a rule of one vector for every type, the same check (weights go by position)
        rule = save_student(tmp_path / f"{name}-rule.json",
                            {t: [0.1] * len(features) for t in CREW_TYPES}, features=features)
        with pytest.raises(ValueError, match="an untyped model reads"):
            stage2.new_candidate_model(candidate_config(candidates=3, start_rule=rule),
                                       distill_model.choice_venv(3))
        out = tmp_path / f"{name}.zip"
        assert distill.main(["student-model", path, "--out", str(out)]) == 2
        assert "--features first" in capsys.readouterr().err and not out.exists()
    other = save_student(tmp_path / "five.json", HAND_WEIGHTS, candidates=5)
    with pytest.raises(ValueError, match="candidates=5"):
        stage2.new_candidate_model(candidate_config(candidates=3, typed=True, start_rule=other),
                                   distill_model.choice_venv(3, len(CREW_TYPES)))


def event_floor(evaluator, seed):
    from cmdp_pymunk import load_case
    from cmdp_pymunk.eventfloor import EventFloor, calibration_for

    case = load_case(None)
    floor = EventFloor(case, evaluator=evaluator, calibration=calibration_for(case))
    floor.reset(seed)
    floor.run()
    return floor


def test_a_held_model_holds_as_the_student_in_deployment_and_training(tmp_path):
    """On the built-in event floor (seed 0) a student that sends RC and FC crews to far
    targets: the model with hold_choice plays its schedule event for event, the one without
    re-decides while crews walk and plays another; the training floor holds as deployment."""
    from agents.specs import evaluator_from_spec
    from agents.student import StudentEvaluator
    from training.research import distill

    far = one_feature("nearness", -5.0)
    student = save_student(tmp_path / "far.json", {"RC": far, "FC": far})
    for hold in (True, False):
        out = tmp_path / f"hold-{hold}.zip"
        assert distill.main(["student-model", student, "--out", str(out)]
                            + ["--hold-choice"] * hold) == 0
    floors = {name: event_floor(evaluator, 0) for name, evaluator in (
        ("student", StudentEvaluator.load(student)), ("eq9", "priority"),
        ("held", evaluator_from_spec(str(tmp_path / "hold-True.zip"))),
        ("unheld", evaluator_from_spec(str(tmp_path / "hold-False.zip"))))}
    assert floors["student"].log.events != floors["eq9"].log.events
    assert floors["held"].log.events == floors["student"].log.events
    assert floors["unheld"].log.events != floors["student"].log.events
    # the training floor (candidate_loop) with the same model and settings: the same floors
    for hold in (True, False):
        config = candidate_config(fidelity="event", candidates=3, typed=True,
                                  hold_choice=hold)
        floor = stage2.make_decision_loop(config, stage2.training_case(config))
        model = evaluator_from_spec(str(tmp_path / f"hold-{hold}.zip")).model

        def choose(obs, floor=floor, model=model):
            action, _ = model.predict(obs[None], action_masks=floor.action_masks()[None],
                                      deterministic=True)
            return action[0]

        played = stage2.play_floor(floor, 0, choose)
        deployed = floors["held" if hold else "unheld"]
        assert played[-1].info["makespan_s"] == deployed.makespan_s
