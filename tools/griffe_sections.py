"""A griffe extension for the docs site: module docstrings written as definition lists become
Markdown sections.

The modules document themselves PettingZoo-style, a term on its own line and its text indented
under it::

    Action space
        ``MultiDiscrete([4, 3, 3])``: ...

Markdown would show the indented text as a code block; this turns each such term into a
heading and dedents its text, so ``::: cmdp_pymunk.adapters.env`` renders the env's page as written.
"""

from __future__ import annotations

import textwrap

import griffe

HEADING = "###"


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


class DefinitionSections(griffe.Extension):
    """Rewrites every module docstring with :func:`definition_sections`."""

    def on_module_instance(self, *, node, mod: griffe.Module, agent, **kwargs) -> None:
        if mod.docstring is not None:
            mod.docstring.value = definition_sections(mod.docstring.value)
