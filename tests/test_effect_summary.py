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


def test_an_azimuth_moves_the_short_way_round():
    """An estimate's shift under the improved model, in the fit's standard
    deviations: an azimuth of 359.95 degrees moving to 0.05 has moved 0.1
    degree (0.5 sd at a 68 % half-width of 0.2), not 359.9."""
    from bayescal.criticism.verdict import improved_estimates

    def ch(median):
        return {"azimuth_deg": {"median": median, "ci68": [median - 0.2, median + 0.2],
                                "ci95": [median - 0.4, median + 0.4]}}

    for before, after, want in ((359.95, 0.05, 0.5), (0.05, 359.95, -0.5), (10.0, 10.1, 0.5)):
        got = improved_estimates({"channels": {"c": ch(before)}}, {"channels": {"c": ch(after)}})
        assert abs(got["c"]["azimuth_deg"]["moved_sd"] - want) < 1e-9, (before, after, got)
