"""The numbers of the README and the docs that no stored result accounts for.

A number on the README, a user-guide page (``docs/*.md``) or a validation
page (``docs/validation/*.md``) is accounted for when it is inside a table
generated from stored results (:mod:`tables`), inside a quote of
``docs/quoted.toml`` (formatted from a stored result), inside code (a
fenced block, an inline ``code`` span: commands, paths, arguments), a link
or a cross-reference, or inside a phrase of the page's ``[allow]`` list in
``docs/quoted.toml``: the numbers that are not results (a study's settings,
a command's defaults, interval levels, band edges, seeds). On the README
and the user guide a ``text`` block that follows an example that runs is
that example's output, checked against the stored one
(``tests/test_doc_numbers.py``); any other ``text`` block (an output
pasted without its example, a file's content) is read as prose. Results
whose runs are not stored are listed apart, in ``[unstored]``, and the page
says that they are not stored. :func:`uncovered` gives the others;
``tests/test_doc_numbers.py`` asks that there be none, so a result typed by
hand onto a page fails.
``python docs/uncovered.py`` lists them, page by page, with their line.
"""
from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import example_outputs  # noqa: E402  (docs/example_outputs.py)
import tables  # noqa: E402  (docs/tables.py)

ROOT = tables.ROOT
QUOTED = ROOT / "docs" / "quoted.toml"
#: The README and the user guide (whose ``text`` blocks are outputs).
GUIDE = [ROOT / "README.md",
         *[ROOT / "docs" / f"{name}.md" for name in
           ("index", "install", "fit", "report", "diagnose", "windows", "noise", "cal", "uvw",
            "batch", "python", "science", "gallery", "architecture")]]
#: The pages whose numbers must be accounted for.
PAGES = [*GUIDE, *sorted((ROOT / "docs" / "validation").glob("*.md"))]
#: A number standing alone (not a digit inside a name such as ``BH1`` or
#: ``STS-1``).
NUMBER = re.compile(r"(?<![\w.])(?<![A-Za-z]-)[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w])")
#: Spans that hold no result: fenced code, inline code, cross-references,
#: link targets and images, HTML comments, inline mathematics.
CODE = [re.compile(r"^(`{3,}).*?^\1\s*$", re.S | re.M), re.compile(r"`[^`]+`"),
        re.compile(r"\]\([^)]*\)"), re.compile(r"<!--.*?-->", re.S), re.compile(r"\$\$.*?\$\$", re.S),
        re.compile(r"(?<!\$)\$(?!\$)[^$]+\$")]
#: Numbers that are never results on these pages: the levels of intervals
#: and bands (68, 90, 95, 99 %, alone or listed: 68/90/95 %), units and
#: exponents (1/s, 1/f, dB re 1 (m/s^2)^2/Hz), channel counts (3+3), seed ranges, the
#: numbers of a numbered list and of a section title, dates and times of
#: day (a record's window), the years of citations and the entries of a
#: reference list.
GENERIC = [re.compile(r"(?<![\w.])(?:68|90|95|99)(?:(?:/|, | and )(?:68|90|95|99))* ?%"),
           re.compile(r"\bre 1 \([^()]*\)\^2/Hz"), re.compile(r"(?<![\w.])1/[sf]\b"),
           re.compile(r"\^\d+\b"), re.compile(r"\b\d\+\d\b"),
           re.compile(r"\bseeds? \d+(?:-\d+)?(?:(?:, \d+(?:-\d+)?)* and \d+(?:-\d+)?)?", re.I),
           re.compile(r"^\s*\d+\. ", re.M), re.compile(r"^#+ .*$", re.M),
           re.compile(r"\b\d{4}-\d\d-\d\dT\d\d:\d\d(?::\d\d)?(?:-\d\d:\d\d)?"),
           re.compile(r"^- .*\((?:19|20)\d\d\)\..*$", re.M),
           re.compile(r"\b\d\d:\d\d\b"),
           re.compile(r"\b(?:19|20)\d\d\)|\((?:19|20)\d\d\)|\b(?:et al\.|and \w+) (?:19|20)\d\d\b")]


def settings():
    """``docs/quoted.toml``: its quotes and its ``[allow]`` lists."""
    return tomllib.loads(QUOTED.read_text())


def words_of(text):
    """A pattern of ``text`` whatever its line breaks and spaces."""
    return re.compile(r"\s+".join(map(re.escape, text.split())))


def blank(text, pattern):
    """``text`` with each match of ``pattern`` blanked (lines kept)."""
    return pattern.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def pasted(page):
    """``(first, end)`` line indices of each ``text`` block of a README or
    user-guide ``page`` that is not the output of the example before it:
    an output pasted without its example, or a file's content."""
    if Path(page) not in GUIDE:
        return []
    shown = {line for _, line, _, _ in example_outputs.quoted([page])}
    return [(line, line + len(body.splitlines()))
            for lang, body, _, _, line in example_outputs.blocks(page)
            if lang == "text" and line not in shown]


def uncovered(page, config=None):
    """``(line, number, the line's text)`` of each number of ``page`` that
    no table, quote, code span or allowed phrase accounts for."""
    config = settings() if config is None else config
    name = str(Path(page).relative_to(ROOT))
    text = Path(page).read_text()
    lines = text.split("\n")
    for first, end in tables.marked(text).values():
        lines[first:end] = [""] * (end - first)
    prose = {i: lines[i] for first, end in pasted(page) for i in range(first, end)}
    text = blank("\n".join(lines), CODE[0])
    lines = text.split("\n")
    for i, line in prose.items():       # a pasted block's lines read as prose
        lines[i] = line
    text = "\n".join(lines)
    phrases = [q["text"] for q in config.get("quote", []) if q["page"] == name]
    phrases += config.get("allow", {}).get(name, []) + config.get("unstored", {}).get(name, [])
    spans = [m.span() for phrase in phrases for m in words_of(phrase).finditer(text)]
    for a, b in spans:                  # every phrase found before any is blanked
        text = text[:a] + re.sub(r"[^\n]", " ", text[a:b]) + text[b:]
    for pattern in CODE[1:] + GENERIC:
        text = blank(text, pattern)
    out = []
    for i, line in enumerate(text.split("\n")):
        out += [(i + 1, m.group(0), Path(page).read_text().split("\n")[i].strip())
                for m in NUMBER.finditer(line)]
    return out


def main():
    """Print each page's numbers that nothing accounts for."""
    config = settings()
    for page in PAGES:
        for line, number, context in uncovered(page, config):
            print(f"{page.relative_to(ROOT)}:{line}: {number}  | {context}")


if __name__ == "__main__":
    main()
