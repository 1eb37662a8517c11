"""The diagnose console in words: the search's rounds (what each kept and
why the others were not), and every estimate that moved, largest first,
dips and gains included."""
from __future__ import annotations

from bayescal.criticism import words
from bayescal.criticism.diagnosis import moves_sentence


def _entry(median, sd):
    return {"median": median, "ci68": [median - sd, median + sd],
            "ci95": [median - 2 * sd, median + 2 * sd]}


def _summary(az, dip, gain):
    response = {"gain": _entry(gain, 12.7), "relative_gain": _entry(gain / 750, 0.017)}
    return {"channels": {"XX.S.10.BH1": {"azimuth_deg": _entry(az, 1.4),
                                         "dip_deg": _entry(dip, 1.6), "response": response}}}


def test_moves_sentence_orders_by_standard_deviations_and_gives_units():
    """Base fit: azimuth 10 +- 1.4, dip 5.58 +- 1.6, gain 686.9 +- 12.7;
    final: azimuth -0.92 deg (0.66 sd), dip -5.6 deg (3.5 sd), gain +58.1
    = +8.5 % of 686.9 (4.57 sd): gain first, then dip, then azimuth; the
    relative gain (the same move) is left out."""
    base = _summary(10.0, 5.58, 686.9)
    final = _summary(10.0 - 0.92, 5.58 - 5.6, 686.9 + 58.1)
    text = moves_sentence(base, final)
    assert text == ("it moves, largest first in the fit's standard deviations: "
                    "XX.S.10.BH1's gain by +8.5 % (4.6 sd), "
                    "XX.S.10.BH1's dip by -5.6 deg (3.5 sd), "
                    "XX.S.10.BH1's azimuth by -0.92 deg (0.66 sd); "
                    "no other estimate moves by more than 0.3 sd")
    assert moves_sentence(base, _summary(10.1, 5.6, 687.0)) is None   # all within 0.3 sd


def test_round_sentences_say_what_was_kept_and_why():
    tried = [{"effect": "timing_offset", "delta_bic": 155683.8},
             {"effect": "extra_pole:sut", "delta_bic": None},
             {"effect": "response_parameters", "delta_bic": 138.4},
             {"effect": "sut_corner", "delta_bic": 174.7}]
    assert words.round_header(1, [], 10.0) == (
        "round 1: each effect of the catalogue scored against the fit (kept when its BIC gain "
        "exceeds 10)")
    assert words.round_header(2, ["timing_offset"], 10.0).startswith(
        "round 2: each effect of the catalogue scored against the fit with timing_offset")
    assert words.round_outcome(1, tried[0], tried, 10.0) == (
        "round 1 keeps timing_offset (BIC gain 155683.8, the best of the round); one effect is "
        "kept per round, so response_parameters, sut_corner (also above 10) are scored again in "
        "round 2 with timing_offset in the model")
    second = [{"effect": "response_parameters", "delta_bic": -24.6},
              {"effect": "sut_corner", "delta_bic": -24.3}]
    assert words.round_outcome(2, second[1], second, 10.0) == (
        "round 2 keeps nothing: no effect improves the fit by a BIC gain above 10 (the largest: "
        "sut_corner, -24.3); the search stops")
    assert words.round_outcome(3, tried[0], tried[:1], 10.0, most=3).endswith(
        "one effect is kept per round; 3 effects at most: the search stops")


def test_fit_console_lists_the_moves_largest_first():
    from bayescal.criticism.verdict import lines

    def move(median, fit, sd):
        return {"median": median, "ci95": [median - 1, median + 1], "fit_median": fit,
                "moved_sd": (median - fit) / sd}
    c = {"verdict": "improved", "verdict_text": "improved", "move_threshold_sd": 0.3,
         "improved_estimates": {"A.B..BH1": {"azimuth_deg": move(1.0, 0.0, 2.0),
                                             "dip_deg": move(5.0, 0.0, 1.0)},
                                "A.B..BH2": {"gain": move(110.0, 100.0, 2.5),
                                             "azimuth_deg": move(90.1, 90.0, 1.0)}}}
    out = lines(c)
    head = out.index("  estimates under the improved model that move by more than 0.3 sd, "
                     "largest first:")
    assert [ln.split()[:2] for ln in out[head + 1:]] == [
        ["A.B..BH1", "dip"], ["A.B..BH2", "gain"], ["A.B..BH1", "azimuth"]]
