"""Stage1Config (a pydantic model): the committed TOML loads, and every bad setting is named
with its fix before anything runs."""

import pytest

from training.stage1 import DEFAULT_CONFIG, Stage1Config


def test_the_committed_config_loads_with_its_values():
    config = Stage1Config.load(DEFAULT_CONFIG)
    assert (config.total_steps, config.gamma, config.net_arch) == (14_000_000, 0.995, [128, 128])
    assert config.stage2_share == 0.15 and config.eval_seeds == [1000, 1001]
    assert Stage1Config.load(DEFAULT_CONFIG, ["seed=3", "net_arch=[64]"]).seed == 3


@pytest.mark.parametrize(("override", "expected"), [
    ("seed=1.5", "seed = 1.5 must be a whole number"),
    ('n_envs="8"', "n_envs = '8' must be a whole number"),
    ("learning_rate=true", "learning_rate = True must be a number"),
    ("batch_size=0", "batch_size = 0 must be positive"),
    ("ent_coef=-0.1", "ent_coef = -0.1 must be zero or positive"),
    ("net_arch=[]", "net_arch = [] must be a non-empty list"),
    ("net_arch=[64, 0]", "net_arch[1] = 0 must be positive"),
    ("eval_seeds=5", "eval_seeds = 5 must be a non-empty list"),
    ("stage2_share=1.5", "stage2_share = 1.5 is a share of the episodes; fix: give a number"),
    ("num_cpus=9", "num_cpus = 9 exceeds n_envs = 8; fix: lower num_cpus"),
])
def test_bad_setting_is_named_with_its_fix(override, expected):
    with pytest.raises(ValueError) as caught:
        Stage1Config.load(DEFAULT_CONFIG, [override])
    assert expected in str(caught.value)


def test_every_problem_is_reported_at_once_naming_the_file(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("seed = -1\nbatch_size = 2.5\n")
    with pytest.raises(ValueError) as caught:
        Stage1Config.load(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: ")
    assert "seed = -1 must be zero or positive" in text
    assert "batch_size = 2.5 must be a whole number" in text


def test_unknown_setting_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown setting.*gama.*known: case, seed"):
        Stage1Config.load(None, ["gama=0.9"])


def test_a_typo_in_set_is_blamed_on_set_not_the_file():
    with pytest.raises(ValueError) as caught:
        Stage1Config.load(DEFAULT_CONFIG, ["totl_steps=3"])
    assert str(caught.value).startswith("--set: unknown setting(s) totl_steps (did you mean "
                                        "total_steps?)")
    with pytest.raises(ValueError) as caught:
        Stage1Config.load(DEFAULT_CONFIG, ["batch_size=0"])
    assert str(caught.value).startswith("--set: batch_size = 0 must be positive")


def test_wandb_asked_for_but_not_installed_says_how(monkeypatch):
    """Weights & Biases is opt-in and no dependency: asking for it without wandb installed
    fails when the settings load (before anything runs), naming --set and the fix."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "wandb" else real(name, *a))
    with pytest.raises(ValueError) as caught:
        Stage1Config.load(DEFAULT_CONFIG, ["wandb_project=cmdp-stage1"])
    assert str(caught.value) == (
        "--set: wandb_project = 'cmdp-stage1' asks for Weights & Biases, but wandb is not "
        "installed; fix: pip install wandb (then wandb login), or drop wandb_project")
    assert Stage1Config.load(DEFAULT_CONFIG).wandb_project is None  # off by default


def test_without_wandb_project_no_callback_is_added():
    from types import SimpleNamespace

    from training.scaffold import wandb_run

    with wandb_run(SimpleNamespace(config=Stage1Config.load(DEFAULT_CONFIG))) as extra:
        assert extra == []


def test_train_reports_the_missing_wandb_with_exit_2(monkeypatch, capsys, tmp_path):
    import importlib.util

    from training.commands import train

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "wandb" else real(name, *a))
    assert train.main(["stage1", "--set", "wandb_project=x", "--out",
                       str(tmp_path / "run")]) == 2
    assert "pip install wandb" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
