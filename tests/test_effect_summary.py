"""What a named effect carries into the summary (result.json
``criticism.effects``): what a pair of recordings cannot tell it from."""
from __future__ import annotations

from types import SimpleNamespace

from bayescal.criticism.effects import ExtraPole
from bayescal.criticism.search import indistinguishable
from bayescal.criticism.verdict import _effect_entry


def test_a_reference_pole_is_a_zero_missing_from_the_sut_in_the_summary():
    """A pole missing from the reference's metadata multiplies the SUT's
    response relative to the reference by ``(1 + i f / fc)``: the same
    relative response as a zero missing from the SUT's metadata, which a
    pair never tells apart; the summary entry says so, with its evidence."""
    pole = ExtraPole([0, 1, 2], "ref", 1.0)
    apart = indistinguishable(SimpleNamespace(effects=[pole]), None, 0)
    entry = {"name": "extra_pole", "channels": ["a", "b", "c"],
             "parameters": {"corner_hz": {"median": 15.5, "ci95": [15.0, 16.0]}, "which": "ref"},
             "explanation": "a pole", **apart}
    got = _effect_entry(entry)
    assert got["indistinguishable_from"] == ["a zero missing from the SUT's metadata"]
    assert got["evidence"] == "a pair of recordings never separates them"
    assert got["size"] == {"corner_hz": {"median": 15.5, "ci95": [15.0, 16.0]}}
    plain = _effect_entry({k: v for k, v in entry.items()
                           if k not in ("indistinguishable_from", "evidence")})
    assert "indistinguishable_from" not in plain and "evidence" not in plain
