"""A griffe extension for the docs site: module docstrings written as definition lists become
Markdown sections.

The modules document themselves PettingZoo-style, a term on its own line and its text indented
under it::

    Action space
        ``MultiDiscrete([4, 3, 3])``: ...

Markdown would show the indented text as a code block; this turns each such term into a
heading and dedents its text, so ``::: cmdp_pymunk.adapters.env`` renders the env's page as written.

Docstrings also name objects Sphinx's way (``:class:`CaseError```); Markdown has no such role,
so every docstring's roles become code spans (``CaseError``). And a docstring's list may follow
its sentence without a blank line, which Markdown reads as one paragraph; one is put there.
"""

from __future__ import annotations

import re
import textwrap

import griffe

HEADING = "###"
ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|exc|obj):`~?([^`]+)`")


def definition_sections(text: str) -> str:
    """Each unindented line followed by lines indented by 4 spaces: a heading over its
    dedented text. Everything else is kept as it is."""
    lines = text.splitlines()
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and not line.startswith(" ") and nxt.startswith("    "):
            body = []
            i += 1
            while i < len(lines) and (lines[i].startswith("    ") or not lines[i].strip()):
                body.append(lines[i])
                i += 1
            while body and not body[-1].strip():
                body.pop()
            out += [f"{HEADING} {line.strip()}", "", textwrap.dedent("\n".join(body)), ""]
            continue
        out.append(line)
        i += 1
    return "\n".join(out)


def sphinx_roles(text: str) -> str:
    """``:class:`X``` (and ``:func:``, ``:meth:``, ...) as the code span ```X```."""
    return ROLE.sub(r"`\1`", text)


def lists_apart(text: str) -> str:
    """A blank line before an unindented ``- `` list that follows a line of text."""
    out: list[str] = []
    for line in text.splitlines():
        prev = out[-1] if out else ""
        if line.startswith("- ") and prev.strip() and not prev.startswith(("- ", " ")):
            out.append("")
        out.append(line)
    return "\n".join(out)


class DefinitionSections(griffe.Extension):
    """Rewrites every module docstring with :func:`definition_sections`, and every docstring
    with :func:`sphinx_roles` and :func:`lists_apart`."""

    def on_module_instance(self, *, node, mod: griffe.Module, agent, **kwargs) -> None:
        if mod.docstring is not None:
            mod.docstring.value = definition_sections(mod.docstring.value)

    def on_instance(self, *, node, obj: griffe.Object, agent, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = lists_apart(sphinx_roles(obj.docstring.value))
