"""The reference lists of the README and the docs, rendered from the one
bibliography, ``docs/references.toml``.

A page holds a reference list between ``<!-- references: KEY KEY ... -->``
and ``<!-- end references -->``; ``python docs/references.py`` rewrites
every such list from the bibliography (one line per key, in the order
given). ``tests/test_doc_references.py`` checks the bibliography's format,
that every list is its rendering, and that the pages cite no DOI and no
author-year that the bibliography does not hold.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BIBLIOGRAPHY = DOCS / "references.toml"
#: A reference list on a page: its keys, then its rendered lines.
LIST = re.compile(r"<!-- references: ([^>]*?) -->\n(.*?)<!-- end references -->", re.DOTALL)


def load():
    """The bibliography: key -> entry."""
    return tomllib.loads(BIBLIOGRAPHY.read_text())


def pages():
    """README.md and every page of the docs."""
    return [ROOT / "README.md", *sorted(p for p in DOCS.rglob("*.md")
                                         if "_build" not in p.parts and "generated" not in p.parts)]


def render(entry):
    """One Markdown list line of ``entry``: authors (year). Title. Where,
    doi or address (what bayescal uses it for)."""
    year = f" ({entry['year']})" if "year" in entry else ""
    link = f"doi:{entry['doi']}" if "doi" in entry else entry.get("url") and f"<{entry['url']}>"
    title = entry["title"] if entry["title"].endswith((".", "?", "!")) else entry["title"] + "."
    text = f"- {entry['authors']}{year}. {title} {entry['where']}"
    text += f", {link}" if link else ""
    return text + (f" ({entry['note']})." if entry.get("note") else ".")


def rendered_list(keys, bib):
    """The lines of a reference list of ``keys``."""
    return "".join(render(bib[k]) + "\n" for k in keys)


def refresh(bib=None):
    """Rewrite every page's reference lists from the bibliography; returns
    the pages changed."""
    bib = bib or load()
    changed = []
    for page in pages():
        text = page.read_text()
        new = LIST.sub(lambda m: f"<!-- references: {m.group(1)} -->\n"
                       f"{rendered_list(m.group(1).split(), bib)}<!-- end references -->", text)
        if new != text:
            page.write_text(new)
            changed.append(page)
    return changed


if __name__ == "__main__":
    for p in refresh():
        print(f"rewrote the references of {p.relative_to(ROOT)}")
