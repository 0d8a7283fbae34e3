"""The layout generator writes valid cases, the published split is what it writes, and the
held-out test layouts finish under the priority heuristic and the scripted navigator."""

import numpy as np
import pettingzoo
import pytest

import cmdp_pymunk
from cmdp_pymunk.adapters.registry import GENERATED
from cmdp_pymunk.cases import generated as layouts
from cmdp_pymunk.cases.load import case_from_dict


def test_published_layouts_are_what_the_generator_writes():
    for split, seeds in (("train", layouts.TRAIN_SEEDS), ("test", layouts.TEST_SEEDS)):
        files = layouts.layout_files(split)
        assert len(files) == len(seeds)
        for k, path in enumerate(files):
            assert path.read_text(encoding="utf-8") == layouts.layout_toml(split, k), \
                f"{path} differs from the generator: run python tools/make_layouts.py"
    assert not set(layouts.TRAIN_SEEDS) & set(layouts.TEST_SEEDS)


def test_every_layout_passes_the_case_check_and_seeds_vary_them():
    shapes = set()
    for seed in range(25):
        data = layouts.generate_layout(seed)
        case = case_from_dict(data, f"seed {seed}")  # raises CaseError on any problem
        assert data == layouts.generate_layout(seed)  # one seed, one layout
        types = [c.type for c in case.crews]
        assert types[:3] == ["JCC", "HIC", "GC"] and 1 <= types.count("RC") <= 2
        assert 1 <= types.count("FC") <= 2
        assert {s.material for s in case.storages} == {"rebars", "templates", "struts"}
        shapes.add((case.plane.width_m, case.plane.height_m, len(case.tasks), len(case.crews)))
    assert len(shapes) >= 15  # the seeds draw different floors


def test_lanes_between_components_let_the_widest_crew_through():
    """HIC: 5 m2 -> diameter 2 sqrt(5 / pi) = 2.52 m; 10 m spacing leaves (10 - 2 - 2) / 2 =
    3 m lanes; 8 m would leave 2 m, where the stage-1 policy wedged crews."""
    assert layouts.lane_width_m(10.0) == 3.0 and layouts.lane_width_m(8.0) == 2.0
    import tomllib

    types = tomllib.loads(cmdp_pymunk.BUILTIN_CASE.read_text())["crew_types"]
    assert layouts.widest_crew_m(types) == pytest.approx(2.523, abs=1e-3)
    for seed in range(25):
        case = case_from_dict(layouts.generate_layout(seed))
        precast = [c for c in case.components if c.kind == "precast"]
        xs = sorted({c.x_m for c in precast})
        ys = sorted({c.y_m for c in precast})
        for axis in (xs, ys):
            for a, b in zip(axis[:-1], axis[1:], strict=True):
                assert layouts.lane_width_m(b - a) >= 2.523 + layouts.LANE_CLEARANCE_M


def test_the_command_writes_the_split(tmp_path):
    assert layouts.main(["--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.glob("*.toml")) == sorted(
        p.name for p in layouts.layout_files("train") + layouts.layout_files("test"))
    assert (tmp_path / "test-0.toml").read_text() == layouts.layout_toml("test", 0)


def test_toml_round_trip_keeps_the_case():
    import tomllib

    data = layouts.generate_layout(7)
    assert case_from_dict(tomllib.loads(layouts.to_toml(data))) == case_from_dict(data)


def test_generated_variants_are_registered_with_their_layout():
    assert len(GENERATED) == len(layouts.TRAIN_SEEDS) + len(layouts.TEST_SEEDS)
    env = pettingzoo.make("parallel", "cmdp/GeneratedFloor-test0-v1", seed=0)
    assert env.case.case.name == "generated-test-0"
    observations, _ = env.reset(seed=0)
    built_in = cmdp_pymunk.parallel_env(seed=0)
    # the same observation as on the built-in floor: a stage-1 policy reads every layout
    assert env.observation_space(env.agents[0]).shape == \
        built_in.observation_space(built_in.possible_agents[0]).shape
    assert all(np.isfinite(o).all() for o in observations.values())


@pytest.mark.slow
@pytest.mark.parametrize("seeds", [
    pytest.param(2, id="sample"),  # the slow set (CI): seeds 0-1, 3-10 s a floor
    pytest.param(5, marks=pytest.mark.nightly, id="all")])  # before a release: 0-4
@pytest.mark.parametrize("path", layouts.layout_files("test"), ids=lambda p: p.stem)
def test_held_out_layouts_finish_with_the_heuristic_and_the_navigator(path, seeds):
    from agents.navigator import Navigator
    from cmdp_pymunk.engine import Engine
    from cmdp_pymunk.evaluate import PriorityEvaluator
    from cmdp_pymunk.rollout import run_episode

    engine = Engine(cmdp_pymunk.load_case(path), stage=2, evaluator=PriorityEvaluator(),
                    park_idle=True)
    navigator = Navigator()
    for seed in range(seeds):
        episode = run_episode(engine, navigator, seed, stall_s=3600.0, progress=False)
        assert episode.stalled is None, (path.name, seed, episode.stalled)
        assert engine.site.done and episode.makespan_s, (path.name, seed)
