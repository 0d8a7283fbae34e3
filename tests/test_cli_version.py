"""Every command-line program answers --version (the console scripts and every module with an
argparse ``main``; a new one without the flag fails here)."""

import configparser
import importlib
from pathlib import Path

import pytest

import cmdp_pymunk

ROOT = Path(__file__).resolve().parent.parent


def console_scripts() -> list[str]:
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    lines = cfg["options.entry_points"]["console_scripts"].strip().splitlines()
    return [line.split("=")[1].strip().split(":")[0] for line in lines if line.strip()]


def cli_modules() -> list[str]:
    found = set(console_scripts())
    for folder in ("training", "training/commands", "media", "benchmarks", "tools", "cmdp_pymunk"):
        for path in (ROOT / folder).glob("*.py"):
            text = path.read_text(encoding="utf-8")
            if "ArgumentParser(" in text and "def main(" in text:
                found.add(f"{folder.replace('/', '.')}.{path.stem}")
    return sorted(found)


def test_the_console_scripts_are_found():
    assert {"training.commands.simulate", "training.commands.train",
            "training.commands.compare_reaching"} <= set(cli_modules())


@pytest.mark.parametrize("module", cli_modules())
def test_version_flag(module, capsys):
    main = importlib.import_module(module).main
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert cmdp_pymunk.__version__ in out and "cmdp_pymunk_v" in out


def test_package_version_is_the_one_setup_cfg_reads():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["metadata"]["version"] == "attr: cmdp_pymunk.about.__version__"


def test_citation_and_license_files():
    cff = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert f"\nversion: {cmdp_pymunk.__version__}\n" in cff  # bump both together
    assert "Construction Process" in cff and "family-names: Xiao" in cff
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("MIT License")


# cmdp-train's stages are parsers of their own
HELP_ARGV = {"training.commands.train": (["--help"], ["stage1", "--help"], ["stage2", "--help"])}


@pytest.mark.parametrize("module", console_scripts())
def test_help_is_complete(module, capsys, monkeypatch):
    """Every command's --help names the command, has a description without RST marks, and
    a help text for every option (a new option without one fails here)."""
    import argparse

    shown = []
    real = argparse.ArgumentParser.print_help
    monkeypatch.setattr(argparse.ArgumentParser, "print_help",
                        lambda self, file=None: shown.append(self) or real(self, file))
    main = importlib.import_module(module).main
    for argv in HELP_ARGV.get(module, (["--help"],)):
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 0
        out = capsys.readouterr().out
        assert out.startswith("usage: cmdp-"), out[:60]
        assert "``" not in out, argv
        parser = shown[-1]
        assert parser.description, argv
        assert [a.dest for a in parser._actions if not a.help] == [], argv
