"""The documentation: its examples run, its words are about the software and
the science, and its build is wired.

* Every fenced code block of README.md and the user-guide pages (docs/*.md)
  is run, in the order a reader meets them, in one scratch folder: ``python``
  blocks in one interpreter namespace, ``bash`` blocks by bash with this
  environment's ``bayescal`` and ``python`` first on the PATH. A ``text``
  block is output (or a file's content) and is not run; when it follows a
  block that ran, each of its lines, numbers masked, must appear in what
  that block printed (a line ``...`` stands for lines left out). A block
  after ``<!-- skip: REASON -->`` is not run (the few commands that set up
  this very environment); one after ``<!-- needs: PATH -->`` runs only when
  ``PATH`` (relative to the repository's parent, e.g. ``../shared/data``)
  exists. The same block text met again (a guide page repeating the
  README's example) is run once. The runner is ``docs/example_outputs.py``,
  which also stores what the examples print (``tests/test_doc_numbers.py``
  checks the quoted numbers against that).
* No words about how the software was made (issue numbers, commit hashes,
  rounds and sessions, dated reruns, the machine and its load) in the
  README, the docs or the package's docstrings and comments.
* The docs build is wired: the ``docs`` extra, ``make docs`` with warnings
  as errors, ``.ci/run`` building the docs after the tests, and a
  configuration that imports and fetches nothing over the network.
"""
from __future__ import annotations

import os
import re
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS))
from example_outputs import PAGES, blocks, mask, quoted, run_pages  # noqa: E402

LANGS = {"python", "bash", "text"}


def test_every_block_is_marked():
    """Only python, bash and text fences; every page of the guide exists."""
    for page in PAGES:
        assert page.is_file(), page
        for lang, _, _, _, line in blocks(page):
            assert lang in LANGS, f"{page.name}:{line}: fence language {lang!r}"


def test_examples_run(tmp_path):
    """Every example runs; each line of the output a page shows (numbers
    masked) is one the example printed."""
    printed, skipped = run_pages(tmp_path)
    bad = []
    for page, line, block, shown in quoted():
        if block not in printed:          # needs data that are absent
            continue
        have = {mask(ln) for ln in printed[block].splitlines()}
        bad += [f"{page.relative_to(ROOT)}:{line}: shown output line not printed:\n{ln}"
                for ln in shown.splitlines() if ln.strip() not in ("", "...")
                and not ln.lstrip().startswith("$ ") and mask(ln) not in have]
    assert not bad, "\n".join(bad)
    # the only commands not run: those that set up this environment or need data
    from tests.conftest import REQUIRE_REAL_DATA, SHARED_DATA
    strict = os.environ.get(REQUIRE_REAL_DATA) == "1" and SHARED_DATA.is_dir()
    for where, why in skipped:
        assert why.startswith(("sets up", "runs this test", "builds the docs")) or \
            (why.endswith("absent") and not strict), (where, why)


# --- no history in user-facing text ----------------------------------------------------------

#: How the software was made belongs in commit messages, not in what users read.
HISTORY = [r"\bissues? #?\d+", r"\bitems? \d+\b",
           r"(?<![\w./-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}(?![\w./-])",
           r"\b(previous|this|last|earlier|next|second|first) (round|session)\b",
           r"\bsessions?\b", r"\b(?:on|of|at) 20\d\d-\d\d-\d\d\b(?!T)", r"\bload average\b",
           r"\bon this machine\b", r"\b(shared|loaded|slower|faster|idle|project) machine\b",
           r"\b2-core machine\b", r"\bother (engineers?|agents?|jobs)\b", r"\bthe brief\b",
           r"\bbefore the fix\b", r"\bnew-user round\b", r"\bcommits? [0-9a-f]{7}",
           r"\btoday('s)?\b", r"\byesterday\b", r"\bthis tree\b", r"\bwas rerun\b"]
HISTORY_RX = re.compile("|".join(f"(?:{p})" for p in HISTORY), re.IGNORECASE)


def _user_facing_files():
    yield ROOT / "README.md"
    for pattern in ("**/*.md", "**/*.rst"):
        yield from (p for p in DOCS.glob(pattern) if "_build" not in p.parts
                    and "generated" not in p.parts)
    yield from (ROOT / "bayescal").rglob("*.py")


def test_no_history_in_user_facing_text():
    hits = []
    for path in _user_facing_files():
        for n, line in enumerate(path.read_text().splitlines(), 1):
            hits += [f"{path.relative_to(ROOT)}:{n}: {m.group(0)!r}: {line.strip()[:100]}"
                     for m in HISTORY_RX.finditer(line)]
    assert not hits, "\n".join(hits)


def test_history_patterns_catch_what_they_should():
    for text in ["as issue 13 asked", "item 4 of the list", "commit 50a0aac", "the previous "
                 "round", "rerun on 2026-11-26", "load average 4.0", "on the 2-core machine",
                 "this session's rerun", "today's defaults"]:
        assert HISTORY_RX.search(text), text
    for text in ["--start 2010-08-24T02:00:00", "relative gain 1.015", "seeds 5000-5299",
                 "1e-9 m/s^2 per count", "each item's result", "the SUT's StationXML"]:
        assert not HISTORY_RX.search(text), text


#: A repository path as the README and the docs cite it (a stored result, a
#: study's or an example's script, a gallery image).
CITED = re.compile(r"(?<![\w/.-])((?:\.\./)*(?:validation|reports|benchmarks|examples|tests)/"
                   r"[\w./*-]+)")


def test_cited_files_exist():
    """Every stored result, script and image the README and the docs cite is
    in the repository (``*`` as a glob); outputs a command writes on the
    reader's machine (``reports/demo/``) and page references (``{doc}``, a
    table of contents' entries) are not files."""
    missing = []
    for page in [ROOT / "README.md", *(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)]:
        for n, line in enumerate(page.read_text().splitlines(), 1):
            for m in CITED.finditer(line):
                cited = m.group(1).rstrip(".,")
                if (line[:m.start()].endswith("{doc}`") or line.strip() == cited      # a page
                        or cited.startswith("reports/demo/")):
                    continue
                base = page.parent if cited.startswith("..") else ROOT
                if not list(base.glob(cited)):
                    missing.append(f"{page.relative_to(ROOT)}:{n}: {cited}")
    assert not missing, "\n".join(missing)


# --- the docs build is wired -------------------------------------------------------------------

def test_docs_build_is_wired():
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["docs"]
    names = {re.split(r"[<>=!~ \[]", r, maxsplit=1)[0].lower() for r in extra}
    assert {"sphinx", "sphinx-argparse", "numpydoc", "myst-parser"} <= names
    assert names & {"furo", "pydata-sphinx-theme"}
    make = (ROOT / "Makefile").read_text()
    rule = make[make.index("\ndocs:"):]
    rule = rule[:rule.find("\n\n")]
    assert "-W" in rule and "--keep-going" in rule and "docs/_build/html" in rule
    ci = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()
          if ln.strip() and not ln.startswith("#")]
    assert ci.index("make test") < ci.index("make docs")
    conf = (DOCS / "conf.py").read_text()
    assert "sphinx.ext.intersphinx" not in conf and "intersphinx_mapping" not in conf
    assert "http" not in conf            # nothing fetched while building
    for ext in ("sphinxarg.ext", "numpydoc", "sphinx.ext.autosummary", "myst_parser"):
        assert f'"{ext}"' in conf, ext
    assert "build_parser" in (DOCS / "cli.rst").read_text()


def test_docs_conf_and_toctree():
    """conf.py executes, and every page under docs/ is in a table of contents
    (a page left out is a build warning, hence an error)."""
    pytest.importorskip("sphinx")
    ns = {"__file__": str(DOCS / "conf.py")}
    cwd = os.getcwd()
    os.chdir(DOCS)
    try:
        exec(compile((DOCS / "conf.py").read_text(), "conf.py", "exec"), ns)
    finally:
        os.chdir(cwd)
    assert ns["html_theme"] in ("furo", "pydata_sphinx_theme")
    listed = set()
    for page in [*DOCS.glob("*.md"), *DOCS.glob("*.rst"), *DOCS.glob("validation/*.md")]:
        for m in re.finditer(r"```\{toctree\}\n(.*?)```", page.read_text(), re.DOTALL):
            base = page.parent.relative_to(DOCS)
            listed |= {str(base / ln.strip()) for ln in m.group(1).splitlines()
                       if ln.strip() and not ln.startswith(":")}
    pages = {str(p.relative_to(DOCS).with_suffix("")) for p in
             [*DOCS.glob("*.md"), *DOCS.glob("*.rst"), *DOCS.glob("validation/*.md")]}
    assert pages - {"index"} <= listed, sorted(pages - {"index"} - listed)


def test_readme_is_short():
    """The README is a front page: at most 250 lines; the rest is in docs/."""
    assert len((ROOT / "README.md").read_text().splitlines()) <= 250


def test_api_reference_lists_what_the_python_page_names():
    """Every function or class the Python page's task table names has its
    page in the API reference (docs/api.rst's autosummary)."""
    import importlib
    import inspect

    api = (DOCS / "api.rst").read_text()
    rows = [ln for ln in (DOCS / "python.md").read_text().splitlines() if ln.startswith("| ")]
    named = {m.group(0) for ln in rows for m in re.finditer(r"\bbayescal(?:\.\w+)+", ln)}
    missing, checked = [], 0
    for name in sorted(named):
        module, _, attr = name.rpartition(".")
        try:
            obj = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError):
            continue                                     # a module, not a function or class
        if inspect.isfunction(obj) or inspect.isclass(obj):
            checked += 1
            if not re.search(rf"^\s+{re.escape(name)}$", api, re.MULTILINE):
                missing.append(name)
    assert checked >= 8 and not missing, missing
