"""Who may import whom, read from the source with ``ast`` (every import, also those inside
functions): the core imports none of the packages built on it, and the two training stages
share code only through the scaffold."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def imported_modules(path: Path) -> set[str]:
    """The absolute names of every module ``path`` imports (relative imports resolved)."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def first_parts(path: Path) -> set[str]:
    return {name.split(".")[0] for name in imported_modules(path)}


@pytest.mark.parametrize("path", sorted((ROOT / "cmdp_pymunk").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_the_core_imports_nothing_built_on_it(path):
    assert not first_parts(path) & {"agents", "training", "media", "benchmarks", "tools"}


def test_the_checker_sees_imports_inside_functions_and_relative_ones(tmp_path):
    sample = ROOT / "training" / "stage2.py"
    names = imported_modules(sample)
    assert "training.scaffold" in names  # ``from .scaffold import ...``
    assert "agents.central_critic" in names  # imported inside ``train``


@pytest.mark.parametrize("module, other", [("stage1", "stage2"), ("stage2", "stage1")])
def test_the_training_stages_do_not_import_each_other(module, other):
    names = imported_modules(ROOT / "training" / f"{module}.py")
    assert not {n for n in names if n == f"training.{other}" or
                n.startswith(f"training.{other}.")}, names
    assert "training.scaffold" in names
    assert "training.train" not in names  # the command imports the stages, not the reverse
