"""tools/check_wheel.py: the wheel and the sdist carry every tracked package file. The quick
half (``setup.cfg`` alone, no build) runs on this checkout; the built half on hand-made
archives. ``make test-wheel`` builds and installs the real wheel (docs/testing.md)."""

from __future__ import annotations

import importlib.util
import io
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_wheel", ROOT / "tools" / "check_wheel.py")
check_wheel = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check_wheel)


@pytest.fixture(scope="module")
def tracked() -> list[str]:
    return check_wheel.tracked_package_files(ROOT, check_wheel.package_roots(ROOT / "setup.cfg"))


def test_the_packages_are_setup_cfgs():
    assert check_wheel.package_roots(ROOT / "setup.cfg") == ["agents", "cmdp_pymunk", "media",
                                                              "training"]


def test_setup_cfg_puts_every_tracked_package_file_in_the_wheel(tracked):
    # the files the commands read without a path given: the built-in cases and calibrations,
    # the layouts, the sample IFC model, the training configs
    for needed in ("cmdp_pymunk/cases/precast_floor.toml",
                   "cmdp_pymunk/cases/precast_floor.event.toml",
                   "cmdp_pymunk/cases/precast_floor.ifc",
                   "cmdp_pymunk/cases/layouts/test-0.event.toml",
                   "training/configs/stage1.toml",
                   "training/runs/__init__.py"):
        assert needed in tracked
    assert check_wheel.left_out(tracked, check_wheel.package_data(ROOT / "setup.cfg")) == []


def test_a_file_setup_cfg_would_leave_out_is_named_with_the_fix():
    files = ["a/__init__.py", "a/x.toml", "a/b/__init__.py", "a/b/y.toml", "a/c/m.py",
             "a/d/z.csv"]
    # "b/*.toml" of package a reaches into its subpackage a.b, as setuptools' glob does
    problems = check_wheel.left_out(files, {"a": ["*.toml", "b/*.toml"]})
    assert problems == [
        "a/c/m.py: its folder a/c has no __init__.py, so the wheel leaves it out; fix: add an "
        "__init__.py there",
        "a/d/z.csv: no pattern of [options.package_data] matches it, so the wheel leaves it "
        "out; fix: add one to setup.cfg, e.g. a = d/*.csv"]
    # "*" stays in one folder: "*.toml" does not take a/b/y.toml
    assert check_wheel.left_out(["a/__init__.py", "a/b/__init__.py", "a/b/y.toml"],
                                {"a": ["*.toml"]}) != []


def _wheel(path: Path, names: list[str]) -> Path:
    with zipfile.ZipFile(path, "w") as zf:
        for name in names:
            zf.writestr(name, "x")
        zf.writestr("cmdp_pymunk-0.0.dist-info/RECORD", "")
    return path


def _sdist(path: Path, names: list[str]) -> Path:
    with tarfile.open(path, "w:gz") as tf:
        for name in names:
            info = tarfile.TarInfo(f"cmdp_pymunk-0.0/{name}")
            info.size = 1
            tf.addfile(info, io.BytesIO(b"x"))
    return path


def test_a_wheel_without_a_tracked_file_fails_naming_it(tmp_path, tracked):
    lost = "cmdp_pymunk/cases/precast_floor.event.toml"
    wheel = _wheel(tmp_path / "cmdp_pymunk-0.0-py3-none-any.whl",
                   [p for p in tracked if p != lost])
    sdist = _sdist(tmp_path / "cmdp_pymunk-0.0.tar.gz", ["setup.cfg", *tracked])
    (line,) = check_wheel.problems(ROOT, wheel, sdist)
    assert line.startswith(f"cmdp_pymunk-0.0-py3-none-any.whl: lacks {lost}; fix: ")
    assert check_wheel.main([str(wheel), str(sdist)]) == 1
    whole = _wheel(tmp_path / "whole.whl", tracked)
    assert check_wheel.problems(ROOT, whole, sdist) == []
    assert check_wheel.main([str(whole), str(sdist)]) == 0


def test_an_sdist_without_a_tracked_file_fails_naming_it(tmp_path, tracked):
    lost = "training/configs/stage1.toml"
    wheel = _wheel(tmp_path / "w.whl", tracked)
    sdist = _sdist(tmp_path / "s.tar.gz", [p for p in tracked if p != lost])
    assert check_wheel.problems(ROOT, wheel, sdist) == [
        f"s.tar.gz: lacks {lost}; fix: add its pattern to [options.package_data] in setup.cfg "
        "(or a MANIFEST.in line)"]
