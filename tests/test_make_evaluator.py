"""Evaluators by name (``evaluate.make_evaluator``) and the one default, Eq. 9, for every
way of making an env."""

import pettingzoo
import pytest

import cmdp_pymunk
from cmdp_pymunk.engine import Engine
from cmdp_pymunk.evaluate import (
    DEFAULT_EVALUATOR,
    EVALUATORS,
    NearestFirstEvaluator,
    PriorityEvaluator,
    RuleAdapter,
    TargetEvaluator,
    make_evaluator,
)
from cmdp_pymunk.move import STAND_STILL


def test_names_objects_and_the_default():
    assert type(make_evaluator("priority")) is PriorityEvaluator
    assert type(make_evaluator("nearest")) is NearestFirstEvaluator
    assert type(make_evaluator(DEFAULT_EVALUATOR)) is EVALUATORS[DEFAULT_EVALUATOR] \
        is PriorityEvaluator
    mine = NearestFirstEvaluator()
    assert make_evaluator(mine) is mine

    class ThreeArguments:  # a rule written before the engine protocol: wrapped, not refused
        def target_values(self, crew, site, position):
            return {t: 1.0 for t in crew.scope}

    old = ThreeArguments()
    wrapped = make_evaluator(old)
    assert isinstance(wrapped, RuleAdapter) and wrapped.rule is old
    assert isinstance(wrapped, TargetEvaluator) and not wrapped.between_seconds


def test_an_unknown_name_names_the_choices_and_the_closest():
    with pytest.raises(ValueError) as err:
        make_evaluator("priorty")
    text = str(err.value)
    assert 'did you mean "priority"?' in text
    assert all(f'"{name}"' in text for name in EVALUATORS)
    with pytest.raises(ValueError, match='give "priority", "nearest"') as err:
        make_evaluator("best")
    assert "did you mean" not in str(err.value)
    with pytest.raises(TypeError, match="is not an evaluator.*values_for"):
        make_evaluator(42)
    with pytest.raises(TypeError, match="is not an evaluator"):
        make_evaluator(None)  # None (values from outside) is the engine's, not an evaluator


def test_every_way_of_making_an_env_has_the_same_default(tiny_case):
    kinds = {type(cmdp_pymunk.CMDPEnv(case=tiny_case).evaluator),
             type(cmdp_pymunk.parallel_env(case=tiny_case).evaluator),
             type(cmdp_pymunk.env(case=tiny_case).unwrapped.evaluator),
             type(pettingzoo.make("parallel", "cmdp/TinyFloor-v1").evaluator),
             type(pettingzoo.make("aec", "cmdp/TinyFloor-v1").unwrapped.evaluator)}
    assert kinds == {PriorityEvaluator}
    # None means one thing at every layer: values come from outside
    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=0, evaluator=None)
    engine = Engine(tiny_case, evaluator=None)
    assert env.evaluator is None and engine.evaluator is None
    env.reset(seed=0)
    assert env.engine.pending  # the crews wait for values, as the engine's do
    with pytest.raises(RuntimeError, match="set_target_values"):
        env.step({agent: STAND_STILL for agent in env.agents})


@pytest.mark.parametrize("name", sorted(EVALUATORS))
def test_parallel_env_takes_a_name_and_runs(tiny_case, name):
    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=0, evaluator=name)
    observations, _ = env.reset(seed=0)
    assert set(observations) == set(env.agents)
    for _ in range(5):
        env.step({agent: STAND_STILL for agent in env.agents})
    assert type(env.evaluator) is EVALUATORS[name]
    valued = [crew for crew in env.engine.site.crews if crew.scope]
    assert valued and all(crew.values.keys() == crew.scope.keys() for crew in valued)
    env.evaluator = "nearest"  # the setter takes a name too
    assert type(env.evaluator) is type(env.engine.evaluator) is NearestFirstEvaluator


def test_the_engine_takes_a_name(tiny_case):
    assert type(Engine(tiny_case, evaluator="nearest").evaluator) is NearestFirstEvaluator
    assert Engine(tiny_case).evaluator is None  # values come from outside
    with pytest.raises(ValueError, match='did you mean "nearest"'):
        Engine(tiny_case, evaluator="nearst")


def test_a_misspelt_strategy_gets_a_did_you_mean():
    import pytest

    from agents.specs import evaluator_from_spec

    with pytest.raises(ValueError, match="did you mean 'priority'"):
        evaluator_from_spec("priorty")
    with pytest.raises(ValueError) as err:
        evaluator_from_spec("runs/missing.zip")  # a model path: no guess among the names
    assert "did you mean" not in str(err.value)
