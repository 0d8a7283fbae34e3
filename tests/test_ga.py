"""Task priorities as an evaluator, priority files, and the GA search
(training/search/genetic.py)."""

import json

import pytest
from conftest import tiny_dict

from agents.specs import evaluator_from_spec
from agents.task_priority import (
    TaskPriorityEvaluator,
    load_priorities,
    save_priorities,
    task_priority_value,
)
from cmdp_pymunk.cases.load import case_from_dict
from training.runs.runner import EpisodeRunner
from training.search.genetic import GAConfig, episode_fitness, run_ga, successor_genes


def far_start_case():
    """The tiny case with the cleaning crew X-1 starting beside B (8, -3): nearest first
    cleans B first, but A's cleaning heads the critical path X-A -> K-A -> M-C (120 + 90 +
    180 s), so the best order by hand is X-A before X-B."""
    data = tiny_dict()
    data["crews"][0]["start_x_m"], data["crews"][0]["start_y_m"] = 8.0, -3.0
    return case_from_dict(data, "far.toml")


def test_task_priority_value_by_hand():
    # p = 0.3, d = 5 of d_max = 10, w = 0.5: 0.3 + 0.5 * (1 - 0.5) = 0.55
    assert task_priority_value(0.3, 5.0, 10.0, 0.5) == pytest.approx(0.55)
    assert task_priority_value(0.3, 0.0, 0.0, 0.5) == pytest.approx(0.8)  # lone target


def test_evaluator_prefers_the_higher_priority_task(tiny_env):
    site = tiny_env.engine.site
    crew = site.crews[0]  # scope A (X-A) and B (X-B)
    ev = TaskPriorityEvaluator({"X-A": 0.2, "K-A": 0.0, "X-B": 0.9, "M-C": 0.0})
    values = ev.target_values(crew, site, tiny_env.engine.positions[0])
    by_task = {site.tasks[crew.scope[t]].id: v for t, v in values.items()}
    assert by_task == {"X-B": 1.0, "X-A": 0.5}  # as_target_values: best 1, worst 0.5


def test_priority_file_round_trip_and_errors(tmp_path, tiny_case):
    path = save_priorities(tmp_path / "p.json", tiny_case,
                           {"X-A": 0.9, "K-A": 0.1, "X-B": 0.2, "M-C": 0.3}, 0.5, "ga")
    ev = evaluator_from_spec(f"ga:{path}")
    assert ev.priorities["X-A"] == 0.9 and ev.distance_weight == 0.5
    ev.check_case(tiny_case)
    data = json.loads(path.read_text())
    del data["priorities"]["M-C"]
    data["priorities"]["Z-9"] = 1.0
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"p.json: no priority for task\(s\) M-C; unknown "
                                         r"task\(s\) Z-9 for case 'tiny'; fix"):
        load_priorities(path).check_case(tiny_case)
    data["priorities"]["X-A"] = float("nan")
    path.write_text(json.dumps(data).replace("NaN", '"nan"'))
    with pytest.raises(ValueError, match=r"priorities\['X-A'\] is 'nan'; fix"):
        load_priorities(path)
    with pytest.raises(ValueError, match="no such priority file; fix"):
        evaluator_from_spec(f"ga:{tmp_path / 'missing.json'}")


def test_simulate_with_a_ga_file(tmp_path):

    import cmdp_pymunk
    from training.commands import simulate

    tiny = cmdp_pymunk.TINY_CASE
    case = __import__("cmdp_pymunk").load_case(tiny)
    path = save_priorities(tmp_path / "g.json", case, {t.id: 0.5 for t in case.tasks}, 0.5, "ga")
    out = tmp_path / "run"
    assert simulate.main(["--case", str(tiny), "--evaluator", f"ga:{path}", "--out", str(out),
                          "--no-charts", "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["all_finished"]


def test_fitness_counts_unfinished_episodes_as_twice_the_limit():
    assert episode_fitness(1000.0, 200, 0.01, 5000.0) == pytest.approx(1002.0)
    assert episode_fitness(None, 0, 0.01, 5000.0) == 10000.0


def test_hand_known_order_is_better():
    runner = EpisodeRunner(far_start_case())
    rows = [runner.run(TaskPriorityEvaluator({"X-A": a, "K-A": 0.5, "X-B": b, "M-C": 0.5}),
                       "scripted", 0) for a, b in ((1.0, 0.0), (0.0, 1.0))]
    assert rows[0]["makespan_s"] < rows[1]["makespan_s"]  # 537 against 655 s here


def test_ga_finds_the_hand_known_order(tmp_path):
    case = far_start_case()
    config = GAConfig(population=6, generations=3, train_seeds=[0], distance_weight=0.0,
                      seed_successors=False, seed=1)
    state = run_ga(case, config, tmp_path, workers=1, progress=False)
    best = load_priorities(tmp_path / "best.json").priorities
    assert best["X-A"] > best["X-B"]
    assert [r["generation"] for r in state.log] == [0, 1, 2, 3]
    assert state.log[-1]["best"] <= state.log[0]["best"]
    assert (tmp_path / "history.csv").read_text().count("\n") == 5


def test_resume_continues_exactly(tmp_path):
    case = far_start_case()
    config = dict(population=4, train_seeds=[0], seed=3, distance_weight=0.0)
    whole = run_ga(case, GAConfig(generations=2, **config), tmp_path / "a", progress=False)
    run_ga(case, GAConfig(generations=1, **config), tmp_path / "b", progress=False)
    with pytest.raises(ValueError, match="other settings"):
        run_ga(case, GAConfig(generations=2, **{**config, "seed": 4}), tmp_path / "b",
               resume=True, progress=False)
    resumed = run_ga(case, GAConfig(generations=2, **config), tmp_path / "b", resume=True,
                     progress=False)
    assert resumed.population == whole.population and resumed.log == whole.log


def test_successor_genes_are_eq9s_first_term(tiny_case):
    # X-A has K-A and M-C after it (2), K-A has M-C (1), X-B and M-C none: / 2
    assert successor_genes(tiny_case) == [1.0, 0.5, 0.0, 0.0]


@pytest.mark.slow
def test_workers_give_the_same_search(tmp_path):
    case = far_start_case()
    config = GAConfig(population=4, generations=1, train_seeds=[0, 1], seed=2)
    one = run_ga(case, config, tmp_path / "one", workers=1, progress=False)
    two = run_ga(case, config, tmp_path / "two", workers=2, progress=False)
    assert one.population == two.population


def test_cmdp_ga_config_errors_and_a_tiny_run(tmp_path, capsys):
    from training.commands import ga

    assert ga.main(["--set", "population=0", "--set", "elite=x", "--out",
                    str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert "population = 0 must be positive" in err and "elite" in err
    tiny = str(__import__("cmdp_pymunk").TINY_CASE)
    out = tmp_path / "run"
    assert ga.main(["--set", f"case='{tiny}'", "--set", "population=3", "--set",
                    "generations=1", "--set", "train_seeds=[0]", "--workers", "1", "--out",
                    str(out), "--no-progress"]) == 0
    for name in ("best.json", "history.csv", "checkpoint.pkl", "config.json"):
        assert (out / name).is_file(), name
    assert ga.main(["--set", f"case='{tiny}'", "--set", "population=3", "--set",
                    "generations=2", "--set", "train_seeds=[0]", "--workers", "1", "--out",
                    str(out), "--no-progress", "--resume"]) == 0
    assert (out / "history.csv").read_text().count("\n") == 4  # header + generations 0-2


def test_equal_genes_on_the_priority_base_rank_as_the_heuristic(tiny_env):
    from cmdp_pymunk.evaluate import PriorityEvaluator

    site = tiny_env.engine.site
    crew = site.crews[0]
    position = tiny_env.engine.positions[0]
    heuristic = PriorityEvaluator().target_values(crew, site, position)
    same = TaskPriorityEvaluator({t.id: 0.5 for t in site.tasks}, base="priority")
    assert same.target_values(crew, site, position) == pytest.approx(heuristic)
    # a gene of 1 against 0 outweighs the heuristic's preference (Eq. 9's V' within 1.5)
    worst = min(heuristic, key=heuristic.get)
    genes = {t.id: 0.0 for t in site.tasks}
    genes[site.tasks[crew.scope[worst]].id] = 2.0
    moved = TaskPriorityEvaluator(genes, base="priority").target_values(crew, site, position)
    assert max(moved, key=moved.get) == worst


def test_the_progress_bar_ends_at_its_total(tmp_path, monkeypatch):
    """The bar counts the first population and each generation's offspring (the elite are
    kept, not replayed): 6 + 3 x (6 - 1) = 21 episodes on one seed; before, its total
    counted the elite too and it stopped short (7/8 of the way with these settings)."""
    import tqdm

    from training.search.genetic import episodes_after

    seen = []

    class Recorder(tqdm.tqdm):
        def close(self):
            if getattr(self, "desc", "").startswith("GA"):  # not the episodes' own (disabled) bars
                seen.append((self.n, self.total))
            super().close()

    monkeypatch.setattr(tqdm, "tqdm", Recorder)
    config = GAConfig(population=6, generations=3, train_seeds=[0], distance_weight=0.0,
                      seed_successors=False, seed=1, elite=1)
    run_ga(far_start_case(), config, tmp_path, workers=1, progress=True)
    assert episodes_after(config, 3) == 21
    assert seen and set(seen) == {(21, 21)}  # before: (21, 24)
