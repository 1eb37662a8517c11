"""Words users read: no internal design-document
names ('the seed', 'seed 003') in the README or any --help, and --quiet
keeps the results table and the band used, both on stdout (a redirection
keeps them; progress and errors go to stderr)."""
from __future__ import annotations

import re
from pathlib import Path

from bayescal.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
INTERNAL = re.compile(r"\bthe seed\b|\bseed 0\d\d|\bseed's\b|shared/seeds", re.IGNORECASE)


def _helps():
    parser = build_parser()
    yield parser.format_help()
    sub = next(a for a in parser._actions if a.dest == "command")
    for p in sub.choices.values():
        yield p.format_help()


def test_no_internal_seed_names_in_readme_or_help():
    assert not INTERNAL.findall((ROOT / "README.md").read_text())
    for text in _helps():
        assert not INTERNAL.findall(text), INTERNAL.findall(text)


def test_quiet_keeps_results_table_and_band(cli_fit):
    proc = cli_fit["proc"]          # the shared run, with --quiet
    assert "band used: 0.03 - 1 Hz" in proc.stdout and "band used" not in proc.stderr
    assert "XX.SIM.10.BH1" in proc.stdout and "azimuth deg [95%]" in proc.stdout


def test_no_internal_seed_names_in_docs():
    for md in sorted((ROOT / "docs").glob("*.md")):
        assert not INTERNAL.findall(md.read_text()), (md.name, INTERNAL.findall(md.read_text()))
