"""The docs site's griffe extension (tools/griffe_sections.py): a module docstring written as a
definition list (a term, its text indented under it) becomes Markdown headings."""

import importlib.util
from pathlib import Path

import pytest

pytest.importorskip("griffe")  # the docs extra (make docs)


def load():
    path = Path(__file__).resolve().parents[1] / "tools" / "griffe_sections.py"
    spec = importlib.util.spec_from_file_location("griffe_sections", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_terms_become_headings_over_their_dedented_text():
    text = ("The env.\n\nAgents\n    One per crew.\n    Two lines.\n\n"
            "Action space\n    ``MultiDiscrete``.\n\nThe end.")
    assert load().definition_sections(text).splitlines() == [
        "The env.", "", "### Agents", "", "One per crew.", "Two lines.", "",
        "### Action space", "", "``MultiDiscrete``.", "", "The end."]


def test_text_without_definitions_is_kept():
    text = "One line.\n\n    an indented block after a blank line stays code"
    assert load().definition_sections(text) == text


def test_sphinx_roles_become_code_spans():
    text = "Raises :class:`CaseError`; see :func:`~cmdp_pymunk.cases.load.load_case` and ``x``."
    assert load().sphinx_roles(text) == (
        "Raises `CaseError`; see `cmdp_pymunk.cases.load.load_case` and ``x``.")


def test_a_list_after_its_sentence_gets_its_blank_line():
    text = "Read so:\n- one\n  more of one\n- two\n\n- three\n    - nested stays"
    assert load().lists_apart(text) == (
        "Read so:\n\n- one\n  more of one\n- two\n\n- three\n    - nested stays")
