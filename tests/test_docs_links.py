"""Links into the docs' sections resolve: README.md and models/README.md are not built by
mkdocs (its --strict check sees only docs/), so a section that moves between docs/results.md
and docs/research-log.md would leave their anchors dangling without this test."""

import re
from pathlib import Path

import pytest

toc = pytest.importorskip("markdown.extensions.toc")  # Python-Markdown, which mkdocs uses

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
LINK = re.compile(r"\]\((?:docs/)?([\w-]+\.md)#([^)\s]+)\)")


def anchors(page: Path) -> set[str]:
    """The ids mkdocs gives the page's headings: Python-Markdown's slugify of the heading's
    text (inline code and emphasis marks dropped), outside fenced code."""
    ids, fenced = set(), False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and (m := re.match(r"#{1,6} (.+)", line)):
            ids.add(toc.slugify(re.sub(r"[`*]", "", m.group(1)).strip(), "-"))
    return ids


def dangling(source: Path) -> list[str]:
    out = []
    for page, anchor in LINK.findall(source.read_text(encoding="utf-8")):
        target = DOCS / page
        if not target.exists() or anchor not in anchors(target):
            out.append(f"{source.relative_to(ROOT)}: {page}#{anchor}")
    return out


def test_slugify_as_mkdocs_does():
    # "The student's ceiling: ..." -> the apostrophe and the colon are dropped, spaces joined
    page = DOCS / "research-log.md"
    assert "the-students-ceiling-the-floors-state-a-search-from-the-student-the-endgame-issue-32" \
        in anchors(page)


@pytest.mark.parametrize("source", ["README.md", "models/README.md"])
def test_readme_links_into_docs_resolve(source):
    assert not dangling(ROOT / source), (
        "a link names a section the docs no longer have; point it at the section's new page "
        "(docs/results.md holds today's numbers, docs/research-log.md the history)")


def test_links_between_docs_pages_resolve():
    bad = [d for page in sorted(DOCS.glob("*.md")) for d in dangling(page)]
    assert not bad, bad


def test_results_keep_the_sections_others_link_to():
    ids = anchors(DOCS / "results.md")
    # README, the docs pages and models/README link to these
    for anchor in ("every-strategy-on-the-80-report-seeds-issue-32-item-6",
                   "stage-2-the-choice-of-targets", "the-ceiling-of-the-target-choice-and-why",
                   "levers-beyond-the-target-choice-what-moves-a-floor", "a-reorder-point",
                   "benchmark-every-registered-variant", "stage-1-the-committed-reaching-model"):
        assert anchor in ids, anchor
