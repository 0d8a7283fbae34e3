"""One SB3 model for both high-level decisions (issue 42 item 6, ``agents.lift``): the target
choice and the lift question, written to start as the student plus the learned logistics rule
(``distill student-model --lift``), and playing exactly their schedule."""

import json
from pathlib import Path

import numpy as np
import pytest

import cmdp_pymunk
from agents.candidates import CandidateModelEvaluator, logistics_of
from agents.lift import ModelLogistics
from agents.specs import evaluator_from_spec
from cmdp_pymunk.evaluate import Evaluator
from cmdp_pymunk.eventfloor import EventFloor, calibration_for
from cmdp_pymunk.logistics import Learned, Logistics, linear_lift
from training.research import distill

MODELS = Path(__file__).resolve().parents[1] / "models"
HIGH_LEVEL = MODELS / "stage2_high_level.zip"
EVALUATOR = MODELS / "stage2_evaluator.zip"
RULE = MODELS / "logistics_learned.json"
STUDENT = MODELS / "api_student_r4.json"


def schedule(floor) -> list[tuple]:
    return [(e.time_s, e.kind, e.crew, e.subject, e.detail) for e in floor.log.events]


def test_the_committed_model_holds_the_student_and_the_rule():
    model = evaluator_from_spec(str(HIGH_LEVEL))
    rule = Learned(RULE)
    assert isinstance(model, CandidateModelEvaluator) and isinstance(model.logistics, Logistics)
    assert model.view.cap == 3 and model.model.action_space.n == 5  # 3 rows, 2 answers
    assert model.logistics.features == rule.features and model.logistics.shares == rule.shares
    meta = json.loads(HIGH_LEVEL.with_suffix(".distill.json").read_text())
    assert meta["command"].startswith("python -m training.research.distill student-model")
    assert meta["lift"]["weights"] == list(rule.weights) and meta["hold_choice"]
    # a model without a lift head answers no lift question: the floor keeps its own logistics
    assert logistics_of(evaluator_from_spec(str(EVALUATOR))) is None
    assert logistics_of(evaluator_from_spec("priority")) is None


def test_lift_answers_equal_the_rules_on_hand_built_features():
    """Thousands of hand-built lift features (each material, stocks from empty to two lifts,
    the crane idle or busy with 0-4 queued, 0-3 crews loading), every crew type: the model's
    argmax is the rule's ``b + w . phi > 0``."""
    model = evaluator_from_spec(str(HIGH_LEVEL))
    rule = Learned(RULE)
    rng = np.random.default_rng(7)
    n = 3000
    material = rng.integers(0, 3, n)
    phi = np.column_stack([material == 0, material == 1, material == 2,
                           rng.uniform(0.0, 2.0, n), rng.integers(0, 2, n),
                           rng.integers(0, 5, n), rng.integers(0, 4, n)]).astype(np.float32)
    assert rule.features[:3] == ("material=rebars", "material=templates", "material=struts")
    types = rng.choice(["JCC", "HIC", "GC", "RC", "FC", "XX"], n)  # XX: outside the vocabulary
    questions = [model.view.lift_question(t, p) for t, p in zip(types, phi, strict=True)]
    obs = np.stack([q[0] for q in questions])
    masks = np.stack([q[1] for q in questions])
    actions, _ = model.model.predict(obs, action_masks=masks, deterministic=True)
    assert set(actions) <= {3, 4}  # only the answers: the rows are masked
    expected = [linear_lift(rule.weights, rule.bias, tuple(map(float, p))) for p in phi]
    assert 0.1 < np.mean(expected) < 0.9  # both answers occur
    assert list(actions == 4) == expected


def tiny_high_level(tmp_path) -> tuple[Path, Path]:
    """A lift rule for the tiny case (its one material, rebars) that answers yes and no along
    a floor, and the high-level model written from it and the committed student."""
    rule = tmp_path / "tiny_rule.json"
    rule.write_text(json.dumps({
        "kind": "cmdp-logistics-linear",
        "features": ["material=rebars", "stock_lifts", "crane_busy", "crane_queue"],
        # lift at half a lift or less while the crane is idle, at a quarter while it is busy
        "weights": [0.6, -1.0, -0.3, -0.5], "bias": 0.0, "shares": [0.75, 0.5, 0.25],
        "meta": {}}))
    model = tmp_path / "high_level.zip"
    assert distill.main(["student-model", str(STUDENT), "--lift", str(rule), "--out",
                         str(model), "--hold-choice"]) == 0
    return model, rule


class BothRoles:
    """A role asking the model and the rule on each state the floor reaches; plays the
    model's answer and records both."""

    def __init__(self, model: ModelLogistics, rule: Learned):
        self.model, self.rule = model, rule
        self.answers: list[tuple[bool, bool]] = []

    def prepare(self, case):
        self.model.prepare(case)
        self.rule.prepare(case)

    def levels(self, material):
        assert self.model.levels(material) == self.rule.levels(material)
        return self.model.levels(material)

    def lift_now(self, engine, i, storage):
        answer = self.model.lift_now(engine, i, storage)
        self.answers.append((answer, self.rule.lift_now(engine, i, storage)))
        return answer


class BothEvaluators(Evaluator):
    """An evaluator asking the new model and ``stage2_evaluator.zip`` on each state; plays the
    new one's values and records both."""

    def __init__(self, new, old):
        self.new, self.old = new, old
        self.values: list[tuple[dict, dict]] = []

    def values_for(self, engine, i):
        values = self.new.values_for(engine, i)
        self.values.append((values, self.old.values_for(engine, i)))
        return values


def test_on_the_tiny_case_both_answers_equal_the_rule_and_the_evaluator(tmp_path, capsys):
    from conftest import play, scripted_floor

    model_path, rule_path = tiny_high_level(tmp_path)
    model = evaluator_from_spec(str(model_path))
    evaluator = BothEvaluators(model, evaluator_from_spec(str(EVALUATOR)))
    role = BothRoles(model.logistics, Learned(rule_path))
    case = cmdp_pymunk.load_case(str(cmdp_pymunk.TINY_CASE))
    for seed in range(6):
        env, navigator = scripted_floor(evaluator, case, seed)
        env.engine.logistics = role
        env.reset(seed=seed)
        navigator.reset(seed)
        assert play(env, navigator).engine.makespan_s is not None
    answers = role.answers
    assert len(answers) >= 12 and {a for a, _ in answers} == {True, False}  # yes and no
    assert all(model_says == rule_says for model_says, rule_says in answers)
    chosen = [new for new, _ in evaluator.values]
    assert len(chosen) > 20 and all(new == old for new, old in evaluator.values)
    # a bad lift rule is refused before anything is written, naming the file and the fix
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(rule_path.read_text()), "weights": [1.0]}))
    out = tmp_path / "never.zip"
    assert distill.main(["student-model", str(STUDENT), "--lift", str(bad), "--out",
                         str(out)]) == 2
    err = capsys.readouterr().err
    assert "--lift" in err and "bad.json" in err and "fix" in err and not out.exists()


@pytest.mark.parametrize("seed", [140, 141, 142])
def test_alone_it_plays_the_evaluator_and_the_rules_event_floor(seed):
    """The event floor of the built-in case (the paper's crews and storages): the new model
    alone, its lift head the floor's logistics as the commands give it (``make_engine`` with
    ``--logistics case``), is ``stage2_evaluator.zip`` plus ``logistics.Learned`` to the
    second, event by event."""
    from training.runs.runner import make_engine

    case = cmdp_pymunk.load_case(None)
    calibration = calibration_for(case)
    new = make_engine(case, evaluator_from_spec(str(HIGH_LEVEL)), "scripted", fidelity="event",
                      calibration=calibration)
    assert isinstance(new.logistics, ModelLogistics)
    old = EventFloor(case, evaluator=evaluator_from_spec(str(EVALUATOR)), stall_s=3600.0,
                     calibration=calibration, logistics=Learned(RULE))
    floors = []
    for floor in (new, old):
        floor.stall_s = 3600.0
        floor.reset(seed)
        floor.run()
        floors.append(floor)
    assert floors[0].makespan_s is not None
    assert any(e.kind == "crane_request" and e.detail == "material" for e in old.log.events)
    assert schedule(floors[0]) == schedule(floors[1])


def test_an_explicit_logistics_spec_overrides_the_lift_head():
    from cmdp_pymunk.logistics import Never
    from training.runs.runner import make_engine

    case = cmdp_pymunk.load_case(None)
    engine = make_engine(case, evaluator_from_spec(str(HIGH_LEVEL)), "scripted",
                         fidelity="event", calibration=calibration_for(case),
                         logistics="never")
    assert isinstance(engine.logistics, Never)


def test_the_benchmark_names_the_lift_head_as_a_role():
    import sys

    sys.path.insert(0, str(MODELS.parent / "benchmarks"))
    from bench_learned_logistics import logistics_spec, role_from_spec

    assert logistics_spec("model") == "case"
    assert isinstance(role_from_spec("model", str(HIGH_LEVEL)), ModelLogistics)
    with pytest.raises(ValueError, match="has no lift head; fix"):
        role_from_spec("model", str(EVALUATOR))


def test_the_fine_tunes_env_answered_by_the_start_replays_the_starts_floor():
    """``lift_finetune.LiftEnv``: one step a lift question; answered by the start's own
    argmax, the floor is the start's (so the shared-seed baseline's reward is exactly 0), and
    only the lift head and the critic are left to learn."""
    from training.research.lift_finetune import LiftEnv, floors, freeze_all_but_lift

    start = evaluator_from_spec(str(HIGH_LEVEL))
    baseline = {r["seed"]: r["makespan_s"] for r in floors(start, [3200])}
    env = LiftEnv(evaluator_from_spec(str(HIGH_LEVEL)), [3200], baseline)
    obs, _ = env.reset()
    done, steps, answers = False, 0, set()
    while not done:
        assert env.observation_space.contains(obs)
        action, _ = env.evaluator.model.predict(obs[None], action_masks=env.action_masks()[None],
                                                deterministic=True)
        answers.add(int(action[0]))
        obs, reward, done, _, _ = env.step(int(action[0]))
        steps += 1
    assert steps > 5 and answers == {3, 4} and reward == 0.0
    assert env.makespans == [(3200, baseline[3200])]
    trainable = freeze_all_but_lift(env.evaluator.model)
    assert {n for n in trainable if n.startswith("action_net.")} == {
        "action_net.lift_linear.weight", "action_net.lift_linear.bias",
        "action_net.lift_per_type.weight"}
    assert any(n.startswith("value_net.") for n in trainable)


def test_the_run_says_the_model_decides_the_lifts(tmp_path):
    # under --logistics case a model with a lift head asks for the lifts: the header and
    # summary.json say so, not "case" (the case's reorder point)
    from agents.lift import has_lift_head, lifts_decided_by

    assert has_lift_head("models/stage2_high_level.zip")
    assert not has_lift_head("models/stage2_evaluator.zip")
    assert not has_lift_head("priority") and not has_lift_head(str(tmp_path / "none.zip"))
    (tmp_path / "bad.zip").write_text("not a zip")
    assert not has_lift_head(str(tmp_path / "bad.zip"))
    assert lifts_decided_by("case", "models/stage2_high_level.zip") == \
        "the evaluator's lift head"
    assert lifts_decided_by("never", "models/stage2_high_level.zip") == "never"
    assert lifts_decided_by("case", "models/stage2_evaluator.zip") == "case"
