"""The one bibliography (docs/references.toml): its format, the reference
lists the README and the docs render from it, and the citations in their
text."""
from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import references  # noqa: E402  (docs/references.py)

DOI = re.compile(r"^10\.\d{4,9}/\S+$")
#: "Sleeman et al. 2006", "Kass and Raftery (1995)", "Sleeman, van Wettum and
#: Trampert's (2006)": the first author's surname and the year.
CITATION = re.compile(r"\b(?:(?:van|ter|de) )?([A-Z][A-Za-z-]+)(?:,? (?:(?:van|ter|de) )?"
                      r"[A-Z][A-Za-z-]+)*(?:,? and (?:(?:van|ter|de) )?[A-Z][A-Za-z-]+| et al\.)?"
                      r"(?:'s)?,? \(?((?:19|20)\d\d)\)?(?![\d-])")


def test_bibliography_format():
    bib = references.load()
    assert bib
    for key, e in bib.items():
        assert re.fullmatch(r"[a-z_]+\d{4}|[a-z_]+", key), key
        assert {"authors", "title", "where"} <= set(e), key
        assert set(e) <= {"authors", "year", "title", "where", "doi", "doi_seen", "url", "note"}, key
        if "year" in e:
            assert isinstance(e["year"], int) and 1900 < e["year"] < 2100, key
            assert key.endswith(str(e["year"])), key
        else:
            assert "url" in e, f"{key}: no year and no address"
        if "doi" in e:               # a DOI only where a published record showed it
            assert DOI.match(e["doi"]), key
            assert e.get("doi_seen", "").startswith(("http://", "https://")), key


def test_every_reference_list_is_rendered_from_the_bibliography():
    bib, lists = references.load(), 0
    for page in references.pages():
        for m in references.LIST.finditer(page.read_text()):
            keys = m.group(1).split()
            assert set(keys) <= set(bib), (page.name, set(keys) - set(bib))
            assert m.group(2) == references.rendered_list(keys, bib), \
                f"{page.name}: its references differ from docs/references.toml " \
                "(python docs/references.py)"
            lists += 1
    assert lists >= 3                     # README, science, cal


def test_every_doi_and_citation_is_in_the_bibliography():
    bib = references.load()
    dois = {e["doi"].lower() for e in bib.values() if "doi" in e}
    firsts = {(e["authors"].split(",")[0].split()[-1], e.get("year")) for e in bib.values()}
    surnames = {name for name, _ in firsts}
    bad = []
    for page in references.pages():
        text = page.read_text()
        bad += [f"{page.name}: doi {d}" for d in re.findall(r"\b10\.\d{4,9}/[^\s,;)>]+", text)
                if d.rstrip(".").lower() not in dois]
        for m in CITATION.finditer(" ".join(text.split())):
            name, year = m.group(1), int(m.group(2))
            if (name in surnames or "et al." in m.group(0)) and (name, year) not in firsts:
                bad.append(f"{page.name}: {m.group(0)}")
    assert not bad, "\n".join(bad)


def test_citation_check_sees_a_wrong_year_and_a_stray_doi():
    assert CITATION.search("(Sleeman et al. 2007)").groups() == ("Sleeman", "2007")
    assert CITATION.search("Sleeman, van Wettum and Trampert's (2006)").groups() == \
        ("Sleeman", "2006")
    assert CITATION.search("ter Braak and Vrugt 2008").groups() == ("Braak", "2008")
    assert CITATION.search("--start 2010-08-24T02:00:00") is None
