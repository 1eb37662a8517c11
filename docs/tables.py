"""The tables the validation pages show, generated from stored results.

A page marks a generated table by an HTML comment on the line before it and
one on the line after it::

    <!-- table: coverage -->
    | parameter | ... |
    |---|---|
    | azimuth | ... |
    <!-- /table -->

and ``docs/tables.toml`` says, for each name, the stored results (JSON files
of the repository, each bound to a short name), the table's head (its
first lines, a template as the rows are) and how each row is written: ``row`` is a template
filled once per entry of ``rows`` (each entry bound to the names of
``vars``; a plain string is bound to ``key``), or ``lines`` lists one
template per row (a table whose rows differ). A template is filled as a
Python f-string would be (:func:`fill`); in it the stored results read as
``cov.table[key].inside`` (attribute or item access,
``cov.channels['US.COWI..LHN']``; ``source[name]`` is the source a row's
entry names) and the helpers of :data:`HELPERS` are at hand.
``python docs/example_outputs.py --no-run`` rewrites every marked table
from its source; ``tests/test_doc_numbers.py`` checks that each is what its
source gives.
"""
from __future__ import annotations

import json
import math
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The generated tables: name -> page, sources, head and rows.
TABLES = ROOT / "docs" / "tables.toml"
START = re.compile(r"^<!-- table: ([\w.-]+) -->\s*$")
END = "<!-- /table -->"


class Stored:
    """A stored result's entry read by attribute or item: containers stay
    :class:`Stored`, leaves are the values themselves."""

    def __init__(self, data, where):
        self.data, self.where = data, where

    def __getitem__(self, step):
        try:
            return wrap(self.data[step], f"{self.where}[{step!r}]")
        except (KeyError, IndexError, TypeError):
            raise LookupError(f"{self.where} has no entry {step!r}") from None

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return self[name]

    def __iter__(self):
        """A dict's keys; a list's items, containers wrapped."""
        if isinstance(self.data, dict):
            return iter(self.data)
        return iter(self.values())

    def __len__(self):
        return len(self.data)

    def values(self):
        """The entries' values, in order (a list's items)."""
        items = self.data.values() if isinstance(self.data, dict) else self.data
        return [wrap(v, self.where) for v in items]


def wrap(value, where):
    """``value`` as read from a stored result: containers wrapped."""
    return Stored(value, where) if isinstance(value, (dict, list)) else value


def binomial_band(n, p=0.9, level=0.99):
    """Central ``level`` band of the count of successes of ``n`` trials
    with probability ``p`` (the studies' :func:`binom.ppf` band)."""
    from scipy.stats import binom

    alpha = 1 - level
    return int(binom.ppf(alpha / 2, n, p)), int(binom.ppf(1 - alpha / 2, n, p))


def chi2_ppf(q, dof):
    """The ``q`` quantile of the chi-square distribution with ``dof``
    degrees of freedom."""
    from scipy.stats import chi2

    return float(chi2.ppf(q, dof))


def chi2_sf(x, dof):
    """The probability that a chi-square variable with ``dof`` degrees of
    freedom exceeds ``x``."""
    from scipy.stats import chi2

    return float(chi2.sf(x, dof))


def md_table(text, n=0):
    """The rows of the ``n``-th markdown table in ``text`` (a study's
    printed summary), each a dict of its head's cells."""
    tables, rows = [], []
    for line in [*str(text).splitlines(), ""]:
        if line.startswith("|"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif rows:
            tables.append([dict(zip(rows[0], r)) for r in rows[2:]])
            rows = []
    return wrap(tables[n], "a markdown table")


def numbers(text):
    """The numbers written in ``text``, as floats."""
    return [float(x) for x in re.findall(r"[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?", str(text))]


def where(rows, **match):
    """The entries of ``rows`` whose fields equal ``match``."""
    return [r for r in rows if all(r[k] == v for k, v in match.items())]


def one(rows, **match):
    """The one entry of ``rows`` whose fields equal ``match``."""
    found = where(rows, **match)
    if len(found) != 1:
        raise LookupError(f"{len(found)} entries match {match}")
    return found[0]


def grab(pattern, text):
    """The first group of ``pattern`` in ``text``."""
    return re.search(pattern, str(text)).group(1)


def example(name):
    """The module ``examples/<name>.py``: a study's own definitions (how it
    summarises its result) for a template to call."""
    import importlib

    if str(ROOT / "examples") not in sys.path:
        sys.path.insert(0, str(ROOT / "examples"))
    return importlib.import_module(name)


def package(name):
    """The module ``bayescal.<name>``: a number a page derives from the
    package's own defaults (a segment length, a default band) is computed by
    the package's function, so the page follows the code."""
    import importlib

    return importlib.import_module(f"bayescal.{name}")


#: Names a template may use besides its sources.
HELPERS = {"bayescal": package, "abs": abs, "max": max, "min": min, "sum": sum, "len": len,
           "round": round, "sqrt": math.sqrt, "band": binomial_band, "sorted": sorted, "enumerate": enumerate,
           "list": list, "zip": zip, "format": format, "example": example,
           "chi2_ppf": chi2_ppf, "chi2_sf": chi2_sf, "log": math.log, "all": all, "any": any,
           "str": str, "lines_of": str.splitlines, "md_table": md_table, "numbers": numbers,
           "grab": grab, "float": float, "int": int, "where": where, "one": one}


def load(sources):
    """The named stored results of ``sources`` (name -> path under the
    repository), each wrapped as :class:`Stored`."""
    return {name: wrap(json.loads((ROOT / path).read_text()), path)
            for name, path in sources.items()}


def field_end(text, start):
    """The index of the brace closing the field opened at ``start``, and
    that of the field's format-spec colon (or -1): brackets, parentheses,
    braces and quoted strings inside the expression are skipped."""
    depth, quote, colon, i = 0, None, -1, start + 1
    while i < len(text):
        c = text[i]
        if quote:
            quote = None if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c in "([{":
            depth += 1
        elif c in ")]}" and depth:
            depth -= 1
        elif c == "}":
            return i, colon
        elif c == ":" and depth == 0 and colon < 0:
            colon = i
        i += 1
    raise ValueError(f"unclosed field in {text!r}")


def fill(template, names):
    """``template`` filled from ``names`` as a Python f-string would be:
    each ``{expression:spec}`` evaluated (the spec may hold fields too),
    ``{{`` and ``}}`` for braces."""
    scope = {"__builtins__": {}, **HELPERS, **names}
    out, i = [], 0
    while i < len(template):
        if template[i:i + 2] in ("{{", "}}"):
            out.append(template[i])
            i += 2
        elif template[i] == "{":
            end, colon = field_end(template, i)
            expr = template[i + 1:colon if colon >= 0 else end]
            spec = fill(template[colon + 1:end], names) if colon >= 0 else ""
            out.append(format(eval(expr, scope), spec))  # noqa: S307  (the repository's own templates)
            i = end + 1
        else:
            out.append(template[i])
            i += 1
    return "".join(out)


def rows_of(spec):
    """The bindings of each row of ``spec``: ``vars`` -> the row's entry."""
    names = spec.get("vars", ["key"])
    return [dict(zip(names, row if isinstance(row, list) else [row])) for row in spec["rows"]]


def table_text(spec):
    """The lines of the table ``spec`` describes, head first."""
    stored = load(spec["sources"])
    head = fill(spec.get("head", "").strip("\n"), stored)
    if "lines" in spec:
        rows = [fill(line, stored) for line in spec["lines"]]
    else:
        rows = [fill(spec["row"], {**stored, **row, "source": stored}) for row in rows_of(spec)]
    return (head.splitlines() if head else []) + rows


def specs():
    """Each table of :data:`TABLES`: name -> spec."""
    return tomllib.loads(TABLES.read_text()).get("table", {})


def marked(text):
    """name -> (first line, line after the last) of each table marked in
    ``text`` (the lines between its two comments)."""
    lines, out, i = text.split("\n"), {}, 0
    while i < len(lines):
        m = START.match(lines[i])
        if m:
            j = i + 1
            while j < len(lines) and lines[j].strip() != END:
                j += 1
            out[m.group(1)] = (i + 1, j)
            i = j
        i += 1
    return out


def refresh_tables():
    """Rewrite every marked table from its source; returns the tables of
    :data:`TABLES` that are not marked on their page."""
    missing, texts = [], {name: table_text(spec) for name, spec in specs().items()}
    for name, spec in specs().items():
        page = ROOT / spec["page"]
        lines = page.read_text().split("\n")
        where = marked("\n".join(lines)).get(name)
        if where is None:
            missing.append(f"{spec['page']}: table {name}")
            continue
        lines[where[0]:where[1]] = texts[name]
        page.write_text("\n".join(lines))
    return missing


def tables_on(page):
    """The marked tables' lines of ``page``: name -> list of lines."""
    lines = Path(page).read_text().split("\n")
    return {name: lines[a:b] for name, (a, b) in marked("\n".join(lines)).items()}
