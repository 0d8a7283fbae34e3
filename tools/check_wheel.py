"""Check that a built wheel and sdist carry every tracked file of the packages they install.

    python tools/check_wheel.py [DIST/cmdp_pymunk-X-py3-none-any.whl [DIST/cmdp_pymunk-X.tar.gz]]

A module or a data file the commands read (the built-in cases and their calibrations, the
generated layouts, the imported IFC model, the training configs) that is tracked by git under
one of the installed packages but missing from the wheel fails here, naming the file and the
fix. Two ways a file goes missing: a ``.gitignore`` line that matched a package folder (the file
is then not even tracked: the fresh install's imports catch that, ``tools/test_wheel.sh``), and
a data file whose pattern ``setup.cfg``'s ``[options.package_data]`` lacks (caught here).

The packages are the ``include`` list of ``setup.cfg``'s ``[options.packages.find]``; a tracked
file under them counts unless it is in ``IGNORED`` (files the wheel is not meant to carry).
The trained models in ``models/`` are not package data: the commands take them by path, from
a checkout (docs/getting-started.md).
Without a wheel only ``setup.cfg`` is checked, without building (``left_out``: a module
outside a package, a data file no pattern matches; ``tests/test_check_wheel.py`` runs it in the
gate). Exit status 0 when nothing is missing, 1 when something is, 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import configparser
import subprocess
import sys
import tarfile
import zipfile
from fnmatch import fnmatch
from pathlib import Path

from cmdp_pymunk import add_version_flag

ROOT = Path(__file__).resolve().parent.parent

# tracked files under a package that no installed command reads (none yet)
IGNORED: tuple[str, ...] = ()


def package_roots(setup_cfg: Path) -> list[str]:
    """The top-level package folders ``setup.cfg`` installs (``cmdp_pymunk``, ``agents``, ...)."""
    cfg = configparser.ConfigParser()
    cfg.read(setup_cfg, encoding="utf-8")
    include = cfg.get("options.packages.find", "include", fallback="")
    return sorted({line.strip().split(".")[0] for line in include.splitlines() if line.strip()})


def tracked_package_files(root: Path, packages: list[str]) -> list[str]:
    """Files git tracks under the package folders, as paths relative to ``root``."""
    out = subprocess.run(["git", "ls-files", "-z", "--", *packages], cwd=root, check=True,
                         capture_output=True, text=True).stdout
    # a tracked file deleted in the work tree is left out, as the next commit would leave it
    return sorted(p for p in out.split("\0") if p and (root / p).is_file()
                  and not any(fnmatch(p, pattern) for pattern in IGNORED))


def package_data(setup_cfg: Path) -> dict[str, list[str]]:
    """``[options.package_data]`` of ``setup.cfg``: package name -> its glob patterns."""
    cfg = configparser.ConfigParser()
    cfg.read(setup_cfg, encoding="utf-8")
    if not cfg.has_section("options.package_data"):
        return {}
    return {pkg: [g.strip() for g in globs.replace("\n", ",").split(",") if g.strip()]
            for pkg, globs in cfg.items("options.package_data")}


def _glob_match(path: str, pattern: str) -> bool:
    """setuptools' glob of a package data pattern: ``*`` stays inside one folder."""
    parts, pats = path.split("/"), pattern.split("/")
    return len(parts) == len(pats) and all(fnmatch(a, b) for a, b in zip(parts, pats, strict=True))


def left_out(tracked: list[str], patterns: dict[str, list[str]]) -> list[str]:
    """Tracked package files that ``setup.cfg`` would leave out of the wheel, with the fix,
    worked out without building: a module in a folder without ``__init__.py`` (``packages =
    find:`` skips the folder) and a data file no ``[options.package_data]`` pattern of its
    package matches. The quick half of the wheel check, for the gate."""
    packages = {p.rsplit("/", 1)[0] for p in tracked if p.endswith("/__init__.py")}
    problems = []
    for path in tracked:
        folders = path.split("/")[:-1]
        outside = ["/".join(folders[:k]) for k in range(1, len(folders) + 1)
                   if "/".join(folders[:k]) not in packages]
        if path.endswith(".py"):
            if outside:
                problems.append(f"{path}: its folder {outside[0]} has no __init__.py, so the "
                                "wheel leaves it out; fix: add an __init__.py there")
            continue
        # setuptools globs a package's patterns from its folder, into subpackages too
        # (cmdp_pymunk's "cases/*.toml"): any package holding the file may match it
        holders = [k for k in range(1, len(folders) + 1) if "/".join(folders[:k]) in packages]
        if not holders:
            problems.append(f"{path}: not inside a package; fix: move it into one")
            continue
        if not any(_glob_match("/".join(path.split("/")[k:]), g)
                   for k in holders for g in patterns.get(".".join(folders[:k]), [])):
            top, inside = folders[0], "/".join(path.split("/")[1:])
            problems.append(f"{path}: no pattern of [options.package_data] matches it, so the "
                            f"wheel leaves it out; fix: add one to setup.cfg, e.g. {top} = "
                            f"{'/'.join([*inside.split('/')[:-1], '*' + Path(inside).suffix])}")
    return problems


def wheel_files(wheel: Path) -> set[str]:
    """The files a wheel installs into site-packages (its ``.dist-info`` left out)."""
    with zipfile.ZipFile(wheel) as zf:
        return {n for n in zf.namelist() if not n.endswith("/") and ".dist-info/" not in n}


def sdist_files(sdist: Path) -> set[str]:
    """The files of an sdist, relative to its top folder (``cmdp_pymunk-X/``)."""
    with tarfile.open(sdist) as tf:
        return {m.name.split("/", 1)[1] for m in tf.getmembers() if m.isfile() and "/" in m.name}


def missing(expected: list[str], present: set[str]) -> list[str]:
    """The expected files that are not present."""
    return [p for p in expected if p not in present]


def problems(root: Path, wheel: Path, sdist: Path | None = None) -> list[str]:
    """One line per tracked package file that the wheel (or the sdist) lacks."""
    expected = tracked_package_files(root, package_roots(root / "setup.cfg"))
    if not expected:
        return [f"{root}: git tracks no file under the packages of setup.cfg; fix: run this "
                "from a git checkout of the project"]
    lines = [f"{wheel.name}: lacks {p}; fix: add its pattern to [options.package_data] in "
             "setup.cfg (or an __init__.py to its folder if it is a module)"
             for p in missing(expected, wheel_files(wheel))]
    if sdist is not None:
        lines += [f"{sdist.name}: lacks {p}; fix: add its pattern to [options.package_data] in "
                  "setup.cfg (or a MANIFEST.in line)"
                  for p in missing(expected, sdist_files(sdist))]
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="check_wheel.py", description=__doc__.split("\n\n")[0])
    add_version_flag(p)
    p.add_argument("wheel", type=Path, nargs="?", default=None,
                   help="the built wheel (.whl); without it only setup.cfg is checked")
    p.add_argument("sdist", type=Path, nargs="?", default=None, help="the built sdist (.tar.gz)")
    p.add_argument("--root", type=Path, default=ROOT, help="the git checkout (default: this one)")
    a = p.parse_args(argv)
    for path in (a.wheel, a.sdist):
        if path is not None and not path.is_file():
            p.error(f"{path} is not a file; fix: build first, python -m build --outdir DIST")
    tracked = tracked_package_files(a.root, package_roots(a.root / "setup.cfg"))
    found = left_out(tracked, package_data(a.root / "setup.cfg"))
    if a.wheel is not None:
        found += problems(a.root, a.wheel, a.sdist)
    for line in found:
        print(f"check_wheel.py: {line}", file=sys.stderr)
    if found:
        return 1
    built = [x.name for x in (a.wheel, a.sdist) if x is not None]
    print(f"check_wheel.py: {' and '.join(built) or 'setup.cfg'} "
          f"{'carry' if len(built) > 1 else 'carries'} all {len(tracked)} tracked package files")
    return 0


if __name__ == "__main__":
    sys.exit(main())
