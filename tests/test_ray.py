"""The Ray backend (training/runs/ray_backend.py) on a two-node Ray cluster started on this machine
(``ray.cluster_utils.Cluster``, 1 CPU per node): the same ``cmdp-evaluate`` episodes as local
processes, a killed worker's job retried or reported, Ctrl-C leaving complete outputs only,
and bad input (an address nobody answers at, workers with another version of this package, a
file missing on a worker) as one line and exit 2 before any episode. Skipped where Ray is not
installed (``pip install -e '.[ray]'``, ``make test-ray``)."""

import json
import os
import secrets
import sys

import pytest
from test_backends import (
    QUICK,
    assert_complete_outputs_only,
    die_always,
    die_once,
    interrupt_evaluate,
    rows_of,
)

import cmdp_pymunk
from training.commands import evaluate_strategies as evaluate
from training.runs.backends import WorkerLost

# As a cluster of `ray start --head` (Ray 2.60's default), with a token: the commands run in a
# child process here send theirs (training/runs/ray_backend.py), and a child in token mode
# cannot use the workers of a cluster without one. Ray reads the mode when it is imported.
os.environ.setdefault("RAY_AUTH_MODE", "token")
TOKEN_FILE = os.path.expanduser("~/.ray/auth_token")
if not (os.environ.get("RAY_AUTH_TOKEN") or os.path.isfile(TOKEN_FILE)):
    # A fresh machine (CI) has no token, and the test cluster does not make one.
    os.environ["RAY_AUTH_TOKEN"] = secrets.token_hex(32)
ray = pytest.importorskip("ray")
pytestmark = pytest.mark.ray


@pytest.fixture(scope="module")
def cluster():
    """Two nodes of 1 CPU each; the tests' drivers join it by its address."""
    from ray.cluster_utils import Cluster

    # The jobs below live in this test module, which the workers cannot import: send them by
    # value.
    for module in ("test_backends", __name__):
        ray.cloudpickle.register_pickle_by_value(sys.modules[module])
    node = {"num_cpus": 1, "object_store_memory": 80 * 1024**2}
    c = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    c.add_node(**node)
    c.wait_for_nodes()
    yield c
    ray.shutdown()
    c.shutdown()


@pytest.fixture
def backend(cluster):
    from training.runs.ray_backend import RayWorkers

    def make(job, retries=1):
        return RayWorkers(job, None, None, cluster.address, retries)
    return make


def test_same_episodes_as_local_processes(cluster, tmp_path):
    outs = {}
    for name, extra in (("local1", ["--workers", "1"]), ("local2", ["--workers", "2"]),
                        ("ray", ["--ray", cluster.address])):
        outs[name] = tmp_path / name
        assert evaluate.main([*QUICK, "--seeds", "0-3", *extra, "--out",
                              str(outs[name])]) == 0
    assert rows_of(outs["ray"]) == rows_of(outs["local1"]) == rows_of(outs["local2"])
    settings = json.loads((outs["ray"] / "settings.json").read_text())
    assert settings["workers"] == 2 and settings["backend"].startswith("Ray on ")


def test_actors_spread_over_both_nodes(backend):
    with backend(die_always) as pool:
        assert len(pool.hosts) == 1  # one machine, but:
        where = ray.get([a.where.remote() for a in pool._actors])
        nodes = ray.get([a.call.remote(_node_id, ()) for a in pool._actors])
    assert len({w["pid"] for w in where}) == 2 and len(set(nodes)) == 2


def _node_id(runner) -> str:
    return ray.get_runtime_context().get_node_id()


def test_a_killed_worker_is_retried(backend, tmp_path):
    with backend(die_once) as pool:
        assert pool.map([(str(tmp_path / "died"), k, 2) for k in range(6)]) == list(range(6))
    assert (tmp_path / "died").exists()


@pytest.mark.parametrize("retries", [0, 1])
def test_a_job_that_kills_every_worker_is_reported_and_only_it(backend, retries):
    got = []
    with pytest.raises(WorkerLost) as err, backend(die_always, retries) as pool:
        for _, k in pool.as_completed([(k, 3) for k in range(6)]):
            got.append(k)
    assert err.value.lost == [3]
    assert sorted(got) == [0, 1, 2, 4, 5]  # handed out before the error


def cpus_free_again(cluster, within_s: float = 30.0) -> bool:
    """Every CPU of the cluster free (no actor holds one) within ``within_s``."""
    import time

    ray.init(address=cluster.address)
    try:
        deadline = time.monotonic() + within_s
        while ray.available_resources().get("CPU", 0) < 2:
            if time.monotonic() > deadline:
                return False
            time.sleep(0.2)
        return True
    finally:
        ray.shutdown()


@pytest.mark.slow
def test_ctrl_c_cancels_and_leaves_complete_outputs_only(cluster, tmp_path):
    out = tmp_path / "run"
    argv = [*QUICK, "--seeds", "0-99", "--ray", cluster.address, "--out", str(out)]
    code, err = interrupt_evaluate(argv, lines=3)
    assert code == 130, err
    assert "Traceback" not in err and "\ncmdp-evaluate: interrupted; " in err, err
    kept = assert_complete_outputs_only(out)
    assert 3 <= len(kept) < 200
    assert cpus_free_again(cluster), "the interrupted run left actors running"
    assert evaluate.main([*argv, "--resume", "--seeds", "0-9"]) == 0


def test_an_address_nobody_answers_at_is_one_line(tmp_path, capsys):
    assert evaluate.main([*QUICK, "--seeds", "0", "--ray", "127.0.0.1:9", "--out",
                          str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-evaluate: --ray 127.0.0.1:9: no Ray cluster answers there")
    assert "ray start --head" in err and "\n" not in err
    assert not (tmp_path / "episodes.jsonl").exists()
    assert evaluate.main([*QUICK, "--ray", "nonsense", "--out", str(tmp_path)]) == 2
    assert "is not an address" in capsys.readouterr().err


def test_workers_with_another_version_are_refused(cluster, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cmdp_pymunk, "__version__", "0.0.0-elsewhere")
    assert evaluate.main([*QUICK, "--seeds", "0", "--ray", cluster.address, "--out",
                          str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "workers run another cmdp-pymunk" in err and "0.0.0-elsewhere here" in err
    assert not (tmp_path / "episodes.jsonl").exists()


def test_a_file_missing_on_a_worker_is_one_line(cluster, tmp_path, capsys, monkeypatch):
    """Here the driver sees the file and the workers do not: its check is skipped."""
    from training.runs import strategies

    monkeypatch.setattr(strategies, "check_specs", lambda *a: None)
    missing = tmp_path / "nowhere.json"
    assert evaluate.main([*QUICK[:2], "--strategies", f"priority,ga:{missing}", *QUICK[4:],
                          "--seeds", "0", "--ray", cluster.address, "--out",
                          str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-evaluate: on worker host ") and str(missing) in err, err
    assert "same path on every node" in err
    assert not (tmp_path / "out" / "episodes.jsonl").exists()


def test_the_ga_searches_the_same_on_ray(cluster, tmp_path):
    from test_ga import far_start_case

    from training.search.genetic import GAConfig, run_ga

    case = far_start_case()
    config = GAConfig(population=4, generations=1, train_seeds=[0, 1], seed=2)
    local = run_ga(case, config, tmp_path / "local", workers=1, progress=False)
    on_ray = run_ga(case, config, tmp_path / "ray", progress=False, workers=None,
                    ray=cluster.address)
    assert on_ray.population == local.population


def test_the_teachers_labels_are_the_same_on_ray(cluster, tmp_path):
    import numpy as np

    from training.research import distill

    tiny = str(cmdp_pymunk.TINY_CASE)
    for name, extra in (("local", []), ("ray", ["--ray", cluster.address, "--workers", "0"])):
        assert distill.main(["label", "--case", tiny, "--seeds", "0-1", "--candidates", "2",
                             "--out", str(tmp_path / name), *extra]) == 0
    for seed in (0, 1):
        a, b = (np.load(tmp_path / name / f"seed-{seed}.npz") for name in ("local", "ray"))
        for key in a.files:
            if key != "wall_s":
                assert np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind == "f"), key


def test_the_rule_search_is_the_same_on_ray(cluster, tmp_path):
    """CMA-ES (cmdp-search-rule) samples from numpy's global generator: Ray must not move it."""
    from test_ga import far_start_case

    from training.search.rule import RuleSearchConfig, search_rule

    config = RuleSearchConfig(features=["nearness"], popsize=3, train_seeds=[0, 1],
                              seeds_per_generation=1, select_seeds=[5], generations=1, seed=2)
    local = search_rule(far_start_case(), config, tmp_path / "local", progress=False)
    on_ray = search_rule(far_start_case(), config, tmp_path / "ray", workers=None,
                         progress=False, ray=cluster.address)
    assert on_ray.log == local.log and on_ray.selection == local.selection


def test_simulate_plays_the_same_seeds_on_ray(cluster, tmp_path):
    """``cmdp-simulate --episodes``: the same seed folders from 2 actors on two nodes as from
    this process."""
    from test_simulate import seed_files

    from training.commands import simulate

    argv = ["--case", str(cmdp_pymunk.TINY_CASE), "--seed", "4", "--episodes", "3",
            "--no-charts", "--no-progress"]
    assert simulate.main([*argv, "--out", str(tmp_path / "here")]) == 0
    assert simulate.main([*argv, "--ray", cluster.address, "--out", str(tmp_path / "ray")]) == 0
    assert seed_files(tmp_path / "ray", (4, 5, 6)) == seed_files(tmp_path / "here", (4, 5, 6))


def test_simulate_with_an_address_nobody_answers_at_is_one_line(tmp_path, capsys):
    from training.commands import simulate

    out = tmp_path / "out"
    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--episodes", "2", "--ray",
                          "127.0.0.1:9", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-simulate: --ray 127.0.0.1:9: no Ray cluster answers there")
    assert "\n" not in err and not out.exists()


def stage2_config(**more):
    from training import stage2

    return stage2.Stage2Config(case=str(cmdp_pymunk.TINY_CASE), n_envs=3, num_cpus=2,
                               central_critic=False, **more)


def test_stage2_floors_on_ray_actors_decide_as_in_local_processes(cluster):
    """``cmdp-train stage2 --ray``'s vector env: 3 floors on 2 actors (one per node) give the
    observations, rewards, ends and end infos of the same floors in 2 local processes, for
    the same seeds and actions, across the floors' resets."""
    import numpy as np

    from training import stage2
    from training.ray_vec_env import RayGroupsVecEnv
    from training.vec_env import ProcessGroupsVecEnv

    config = stage2_config()
    case = stage2.training_case(config)
    here = stage2.make_vec_env(config, case, seed=4)
    there = stage2.make_vec_env(config, case, seed=4, ray=cluster.address)
    try:
        assert isinstance(here.venv, ProcessGroupsVecEnv)
        assert isinstance(there.venv, RayGroupsVecEnv) and len(there.venv.actors) == 2
        np.testing.assert_array_equal(there.reset(), here.reset())
        actions = np.random.default_rng(0).uniform(-1, 1, (40, 3, 2)).astype(np.float32)
        ends = 0
        for a in actions:
            obs, rewards, dones, infos = here.step(a)
            obs_r, rewards_r, dones_r, infos_r = there.step(a)
            np.testing.assert_array_equal(obs_r, obs)
            np.testing.assert_array_equal(rewards_r, rewards)
            np.testing.assert_array_equal(dones_r, dones)
            for info, info_r in zip(infos, infos_r, strict=True):
                for key in ("makespan_s", "stalled"):
                    assert info_r.get(key) == info.get(key), key
                if "episode" in info:  # VecMonitor's return and length; its "t" is wall time
                    assert info_r["episode"]["r"] == info["episode"]["r"]
                    assert info_r["episode"]["l"] == info["episode"]["l"]
            ends += int(dones.sum())
        assert ends >= 2, "no floor ended: the resets were not compared"
        assert there.get_attr("actor_size", [0]) == here.get_attr("actor_size", [0])
    finally:
        here.close()
        there.close()
    assert not ray.is_initialized()  # closing left the cluster as it found it


@pytest.mark.slow
def test_cmdp_train_stage2_on_ray_learns_the_same_weights(cluster, tmp_path):
    """A short stage-2 run whose floors are on the cluster's actors trains the same weights
    as one whose floors are in 2 local processes."""
    import torch as th
    from stable_baselines3 import PPO

    from training.commands.train import main

    argv = ["stage2", "--no-progress", "--set", f"case={cmdp_pymunk.TINY_CASE}",
            "--set", "n_envs=3", "--set", "num_cpus=2", "--set", "central_critic=false",
            "--set", "total_steps=48", "--set", "n_steps=16", "--set", "batch_size=16",
            "--set", "n_epochs=1", "--set", "bc_episodes=0", "--set", "eval_seeds=[2000]",
            "--set", "eval_every_steps=48", "--set", "checkpoint_every_steps=48"]
    assert main([*argv, "--out", str(tmp_path / "here")]) == 0
    assert main([*argv, "--ray", cluster.address, "--out", str(tmp_path / "ray")]) == 0
    a, b = (PPO.load(tmp_path / name / "final_model.zip") for name in ("here", "ray"))
    assert a.num_timesteps == b.num_timesteps >= 48
    for (name, x), (_, y) in zip(a.policy.state_dict().items(), b.policy.state_dict().items(),
                                 strict=True):
        assert th.equal(x, y), name


def test_cmdp_train_with_an_address_nobody_answers_at_is_one_line(tmp_path, capsys):
    from training.commands.train import main

    out = tmp_path / "run"
    assert main(["stage2", "--ray", "127.0.0.1:9", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cmdp-train: --ray 127.0.0.1:9: no Ray cluster answers there")
    assert "\n" not in err and not out.exists()
