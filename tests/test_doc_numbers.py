"""The numbers the README and the docs quote are those of stored results.

* Every ``text`` block of README.md and the user-guide pages that shows what
  an example printed is checked, line by line and numbers included, against
  that example's stored output (``docs/gallery/outputs.json``, written by
  ``python docs/example_outputs.py``); an example edited without its output
  regenerated has no stored output and fails.
* Every number quoted in prose is listed in ``docs/quoted.toml`` with the
  stored result (a JSON file in the repository) and the entry it comes
  from; each is formatted from that entry and must appear on its page.
* Every table a page marks (``<!-- table: NAME -->``) is what
  ``docs/tables.toml`` formats from its stored results.
* Every number of the README, the user guide and the validation pages is
  in such a table, a quote, an example's stored output, code, or a phrase
  its ``[allow]`` list names as a setting (``docs/uncovered.py``); an
  output pasted on a guide page without its example counts as prose.

``tests/test_docs.py`` runs the examples again and checks the quoted
lines' words (numbers masked) against the live output.
"""
from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import example_outputs  # noqa: E402  (docs/example_outputs.py)


def _words(line):
    return " ".join(line.split())


def _stored():
    return json.loads(example_outputs.STORED.read_text())


def test_every_quoted_output_is_a_stored_one():
    stored, bad = _stored(), []
    for page, line, block, shown in example_outputs.quoted():
        where = f"{page.relative_to(ROOT)}:{line}"
        entry = stored.get(example_outputs.key(block))
        if entry is None:
            bad.append(f"{where}: its example has no stored output "
                       "(python docs/example_outputs.py)")
            continue
        have = {_words(ln) for ln in entry["printed"].splitlines()}
        bad += [f"{where}: not in the stored output: {ln.strip()}" for ln in shown.splitlines()
                if ln.strip() not in ("", "...") and not ln.lstrip().startswith("$ ")
                and _words(ln) not in have]
    assert not bad, "\n".join(bad)


def test_stored_outputs_are_of_the_pages_examples():
    """No stored output of an example the pages no longer hold."""
    blocks = {example_outputs.key(body) for page in example_outputs.PAGES
              for lang, body, *_ in example_outputs.blocks(page) if lang in ("python", "bash")}
    assert set(_stored()) <= blocks


def quoted_numbers():
    """Each ``[[quote]]`` of docs/quoted.toml."""
    return tomllib.loads(example_outputs.QUOTED.read_text())["quote"]


@pytest.mark.parametrize("quote", quoted_numbers(), ids=lambda q: f"{q['page']}:{q['text']}")
def test_prose_numbers_are_the_stored_results(quote):
    text = example_outputs.quoted_value(quote)
    assert text == quote["text"], f"{quote.get('source', quote.get('sources'))}: {text!r}"
    page = " ".join((ROOT / quote["page"]).read_text().split())
    assert quote["text"] in page, f"{quote['page']} does not quote {quote['text']!r}"


def test_refresh_rewrites_each_quoted_line_from_its_own_output_line(tmp_path):
    """Of the stored lines that say the same (numbers masked), a quoted line
    is rewritten from the one sharing its words (its row's label, its
    channel's id); a line no stored line says is left and reported."""
    block = 'print("table")\n'
    page = tmp_path / "page.md"
    page.write_text("```python\n" + block + "```\n\n```text\n...\nBH2 0.3-1 9.9\n"
                    "BH1 0.25-0.3 9.9\nnot printed 1\n```\n")
    printed = "BH1 0.25-0.3 1.0\nBH1 0.3-1 2.0\nBH2 0.25-0.3 3.0\nBH2 0.3-1 4.0\n"
    stored = {example_outputs.key(block): {"block": block, "printed": printed}}
    missing = example_outputs.refresh_page(page, stored)
    assert page.read_text().splitlines()[6:9] == ["BH2 0.3-1 4.0", "BH1 0.25-0.3 1.0",
                                                  "not printed 1"]
    assert missing == ["page.md:9: not printed 1"]


import tables  # noqa: E402  (docs/tables.py)
import uncovered  # noqa: E402  (docs/uncovered.py)


@pytest.mark.parametrize("name", sorted(tables.specs()))
def test_marked_tables_are_the_stored_results(name):
    """Each table of docs/tables.toml, marked on its page, is line for line
    what its stored results give."""
    spec = tables.specs()[name]
    shown = tables.tables_on(ROOT / spec["page"]).get(name)
    assert shown is not None, f"{spec['page']} marks no table {name!r}"
    assert shown == tables.table_text(spec), (
        f"{spec['page']}: table {name} is not what {spec['sources']} give "
        "(python docs/example_outputs.py --no-run)")


def test_every_marked_table_has_a_source():
    specs = tables.specs()
    for page in uncovered.PAGES + example_outputs.PAGES:
        for name in tables.tables_on(page):
            assert specs.get(name, {}).get("page") == str(page.relative_to(ROOT)), (page, name)


def test_a_table_is_rewritten_from_its_source(tmp_path, monkeypatch):
    """A hand-edited cell is put back from the stored result, a derived
    column (a pooled binomial band) included; the text around is kept."""
    (tmp_path / "r.json").write_text(json.dumps({"t": {"a": {"k": 91, "n": 100}}}))
    page = tmp_path / "p.md"
    page.write_text("before\n<!-- table: t -->\n| a | 99 | [1, 2] |\n<!-- /table -->\nafter\n")
    (tmp_path / "t.toml").write_text(
        '[table.t]\npage = "p.md"\nsources = {r = "r.json"}\nrows = ["a"]\n'
        'row = "| {key} | {r.t[key].k} | [{band(r.t[key].n)[0]}, {band(r.t[key].n)[1]}] |"\n')
    monkeypatch.setattr(tables, "ROOT", tmp_path)
    monkeypatch.setattr(tables, "TABLES", tmp_path / "t.toml")
    assert tables.refresh_tables() == []
    # 99 % binomial band of 100 trials at 0.9: [82, 97] (binom.ppf 0.005, 0.995)
    assert page.read_text() == ("before\n<!-- table: t -->\n| a | 91 | [82, 97] |\n"
                                "<!-- /table -->\nafter\n")


def _pending():
    return uncovered.settings().get("pending", {})


@pytest.mark.parametrize("page", uncovered.PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_numbers_come_from_stored_results(page):
    """Every number of the README, a user-guide page or a validation page
    is in a generated table, a quote of docs/quoted.toml, an example's
    output checked against its stored one, code, or a phrase the page's
    [allow] list names as a setting; a page of [pending] still has numbers
    typed by hand (it leaves the list when it has none)."""
    left = uncovered.uncovered(page)
    name = str(page.relative_to(ROOT))
    if name in _pending():
        assert left, f"{name} has no number left by hand: take it off [pending]"
        return
    assert not left, "\n".join(f"{name}:{line}: {number} ({text})" for line, number, text in left)


def test_only_numbers_nothing_accounts_for_are_reported(tmp_path, monkeypatch):
    """A number in a marked table, a quote, code, mathematics, an allowed
    phrase or a generic form (an interval level, a seed range, a year) is
    accounted for; a result typed into prose is not, and is reported with
    its line."""
    page = tmp_path / "p.md"
    page.write_text("# Study 1\n\n<!-- table: t -->\n| a | 12 |\n<!-- /table -->\n\n"
                    "Seeds 0-99 of 200 simulated pairs, 95 % intervals ($a = 2$), `--n 7`.\n"
                    "The fit holds 183 of 200 (Sleeman 2006); the bias is\n0.31 sd.\n"
                    "```text\nrun 44\n```\n")
    config = {"quote": [{"page": "p.md", "text": "holds 183 of 200"}],
              "allow": {"p.md": ["of 200 simulated pairs"]}}
    monkeypatch.setattr(uncovered, "ROOT", tmp_path)
    assert [(line, number) for line, number, _ in uncovered.uncovered(page, config)] == [(9, "0.31")]


@pytest.mark.parametrize("page", uncovered.GUIDE, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_allowed_phrase_of_a_guide_page_is_on_it(page):
    """An [allow] phrase of the README or a guide page that the page no
    longer holds is stale: a setting list names only what the page says."""
    name = str(page.relative_to(ROOT))
    text = page.read_text()
    stale = [phrase for phrase in uncovered.settings().get("allow", {}).get(name, [])
             if not uncovered.words_of(phrase).search(text)]
    assert not stale, f"{name}: [allow] phrases not on the page: {stale}"


def test_a_pasted_output_on_a_guide_page_reads_as_prose(tmp_path, monkeypatch):
    """On a README or user-guide page the output shown after an example is
    checked against its stored output, so its numbers are accounted for;
    an output pasted without its example is prose, its numbers reported.
    Interval levels listed together, units and exponents are generic."""
    page = tmp_path / "guide.md"
    page.write_text("Run it:\n\n```bash\nbayescal fit --band 0.03 1\n```\n\n```text\n"
                    "azimuth 3.253 [2.681, 3.814]\n```\n\nAnother run prints:\n\n```text\n"
                    "azimuth 4.5 [4.1, 4.9]\n```\n\nIts 68/90/95 % intervals, in dB re 1 "
                    "(m/s^2)^2/Hz and 1/s.\n")
    monkeypatch.setattr(uncovered, "ROOT", tmp_path)
    monkeypatch.setattr(uncovered, "GUIDE", [page])
    assert [(line, number) for line, number, _ in uncovered.uncovered(page, {})] == [
        (14, "4.5"), (14, "4.1"), (14, "4.9")]
    monkeypatch.setattr(uncovered, "GUIDE", [])         # a validation page: fenced blocks are code
    assert uncovered.uncovered(page, {}) == []


def test_a_template_is_filled_as_an_f_string():
    """Fields with quotes, brackets and colons inside, a spec holding a
    field, and doubled braces, as Python's own f-strings give them."""
    names = {"d": tables.wrap({"a b": [1.23456, 2], "k": {"x": 3}}, "d"), "f": ".2f"}
    template = "{{doc}} {d['a b'][0]:{f}} {d.k.x:+d} {':'.join(['p', 'q'])} {d['a b'][0:1][0]:.1e}"
    assert tables.fill(template, names) == "{doc} 1.23 +3 p:q 1.2e+00"


def test_every_unstored_phrase_is_on_its_page_and_marked():
    """An [unstored] phrase names a result the page shows without a stored
    run: it must still be on its page (else the list is stale), and the
    page must say "not stored" (so a reader knows)."""
    for name, phrases in uncovered.settings().get("unstored", {}).items():
        text = (ROOT / name).read_text()
        stale = [p for p in phrases if not uncovered.words_of(p).search(text)]
        assert not stale, f"{name}: [unstored] phrases not on the page: {stale}"
        assert "not stored" in text, f"{name} lists unstored results but does not say so"
