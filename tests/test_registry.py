"""The registered variants pass PettingZoo's own tests (api, parallel api, seed, state) with no
warning about unbounded spaces; ``env()`` is the AEC API beside ``parallel_env()``."""

import warnings

import pettingzoo
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test
from pettingzoo.test.state_test import state_test

import cmdp_pymunk
from cmdp_pymunk.adapters.registry import GENERATED, VARIANTS
from cmdp_pymunk.evaluate import make_evaluator

# warnings we accept, each by design: MultiDiscrete actions (section 3.6.2), the constant
# all-zero observation of a crew that needs no movement decision, crew ids as agent names
ACCEPTED = ("Action space for each agent probably should be",
            "Observation numpy array is all zeros",
            "We recommend agents to be named in the format")


def test_variants_are_registered_under_both_apis():
    for env_id in VARIANTS:
        assert env_id in pettingzoo.parallel_registry and env_id in pettingzoo.aec_registry
    assert {"cmdp/PrecastFloor-v1", "cmdp/PrecastFloor-stage1-v1", "cmdp/TinyFloor-v1",
            "cmdp/GeneratedFloor-train0-v1", "cmdp/GeneratedFloor-test0-v1"} <= set(VARIANTS)
    tiny = pettingzoo.make("parallel", "cmdp/TinyFloor-v1")
    assert tiny.case == cmdp_pymunk.load_case(cmdp_pymunk.TINY_CASE)
    env = pettingzoo.make("parallel", "cmdp/PrecastFloor-v1", seed=3)
    assert isinstance(env, cmdp_pymunk.CMDPEnv) and env.stage == 2
    assert env.metadata["name"] == "cmdp_pymunk_v1"
    assert type(env.evaluator).__name__ == "PriorityEvaluator"
    stage1 = pettingzoo.make("parallel", "cmdp/PrecastFloor-stage1-v1", evaluator="nearest")
    assert stage1.stage == 1 and stage1.max_time_s == 3000.0
    assert type(stage1.evaluator).__name__ == "NearestFirstEvaluator"
    # unversioned ids resolve to the latest version
    assert pettingzoo.make("parallel", "cmdp/PrecastFloor").stage == 2
    with pytest.raises(ValueError, match='give "priority", "nearest"'):
        make_evaluator("best")


# every variant; of the generated layouts, one of each split in the fast tests; the reorder
# floor is the built-in floor but for its materials' reorder points (tests/test_reorder.py)
FAST = [v for v in VARIANTS if (v not in GENERATED or v.endswith(("-train0-v1", "-test0-v1")))
        and v != "cmdp/PrecastFloor-reorder-v1"]


@pytest.mark.parametrize("env_id", [pytest.param(v, marks=[] if v in FAST else pytest.mark.slow)
                                    for v in VARIANTS])
def test_pettingzoo_tests_pass_without_space_warnings(env_id):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        api_test(pettingzoo.make("aec", env_id, seed=0), num_cycles=200)
        parallel_api_test(pettingzoo.make("parallel", env_id, seed=0), num_cycles=200)
        seed_test(lambda: pettingzoo.make("aec", env_id), num_cycles=100)
        parallel_seed_test(lambda: pettingzoo.make("parallel", env_id), num_cycles=100)
        state_test(pettingzoo.make("aec", env_id, seed=0),
                   pettingzoo.make("parallel", env_id, seed=0))
    unexpected = {str(w.message) for w in caught} - {
        str(w.message) for w in caught if str(w.message).startswith(ACCEPTED)}
    assert not unexpected, unexpected


def test_aec_env_beside_parallel_env(tiny_case):
    aec = cmdp_pymunk.env(case=tiny_case, seed=0)
    api_test(aec, num_cycles=100)
    aec.reset(seed=0)
    assert aec.state().shape == aec.state_space.shape
    assert aec.possible_agents == cmdp_pymunk.parallel_env(case=tiny_case).possible_agents
