"""Every script in examples/ runs, with tiny settings (a few seconds each)."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_example_is_tested():
    assert {p.stem for p in EXAMPLES.glob("*.py")} == {"quickstart", "random_agent",
                                                        "ppo_tiny", "gantt"}


def test_quickstart_builds_the_tiny_floor(capsys):
    makespan = load("quickstart").main(["--env", "cmdp/TinyFloor-v1"])
    assert makespan > 0 and f"makespan {makespan:,.0f} s" in capsys.readouterr().out


def test_random_agent_plays_its_steps(capsys):
    returns = load("random_agent").main(["--steps", "50"])
    assert set(returns) == {"HIC-1", "RC-1"}
    assert "cmdp/TinyFloor-v1: 50 steps" in capsys.readouterr().out


def test_gantt_example_writes_both_charts(tmp_path):
    paths = load("gantt").main(["--out", str(tmp_path)])
    assert [p.name for p in paths] == ["gantt_agents.png", "gantt_tasks.png"]
    assert all(p.stat().st_size > 1000 for p in paths)


def test_ppo_example_learns_and_evaluates():
    out = load("ppo_tiny").main(["--steps", "512", "--eval-steps", "20"])
    assert out["steps"] >= 512 and isinstance(out["ppo"], float)


@pytest.mark.slow
def test_ppo_example_for_its_two_minutes():
    out = load("ppo_tiny").main([])
    assert out["steps"] > 10_000
