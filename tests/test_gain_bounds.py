"""The bounds a pair's spectra put on a SUT gain whatever the two sensors'
self-noise (``S_yx/S_xx <= g <= S_yy/S_yx``), their standard errors, the
SUT-side gain, and the "not separable" flag of a fit
(:mod:`bayescal.core.checks.gain_bounds`)."""
from __future__ import annotations

import io
import warnings

import numpy as np
import pytest

import bayescal.core.checks.gain_bounds as gb

#: A ground spectrum with a microseism peak over eight bands, band sums.
GROUND = np.array([1.0, 2.0, 6.0, 20.0, 9.0, 3.0, 1.5, 1.0])
SMOOTH = np.stack([np.ones(8), np.linspace(3.0, 0.5, 8)], axis=1)      # two noise shapes
DOF = np.full(8, 400.0)


def _sums(g, x, noise_u):
    """Exact band sums of ``y = g s + n_u``, ``x = s + n_r`` with the
    reference's noise ``x`` times the ground (ground-shaped)."""
    return GROUND * (1 + x), g * GROUND + 0j, g * g * GROUND + noise_u


@pytest.mark.parametrize("g, x, scale", [(1.03, 0.1, 0.5), (0.97, 0.0, 2.0), (1.0, 0.4, 0.0)])
def test_bounds_are_the_closed_form_and_hold_the_gain(g, x, scale):
    noise_u = scale * SMOOTH @ np.array([1.0, 0.5])
    a, c, y = _sums(g, x, noise_u)
    lower, upper, _, _ = gb.bounds(a, c, y, DOF)
    s = GROUND.sum()
    assert lower == pytest.approx(g / (1 + x), rel=1e-12)
    assert upper == pytest.approx(g + noise_u.sum() / (g * s), rel=1e-12)
    assert lower <= g <= upper


def test_bounds_collapse_to_the_gain_without_noise():
    lower, upper, _, _ = gb.bounds(*_sums(1.021, 0.0, 0.0), DOF)
    assert lower == pytest.approx(1.021, rel=1e-12) and upper == pytest.approx(1.021, rel=1e-12)


def test_sut_side_gain_is_exact_on_smooth_sut_noise():
    """Reference noise shaped like the ground (x = 0.25), SUT noise a
    combination of the two smooth shapes: the regression gives g and x."""
    g, x = 1.04, 0.25
    a, c, y = _sums(g, x, SMOOTH @ np.array([2.0, 1.0]))
    sides = gb.side_gains(a, c, y, DOF, SMOOTH, SMOOTH)
    gain, sd = sides["sut"]
    assert gain == pytest.approx(g, rel=1e-9)
    assert sides["fraction"] == pytest.approx(x, rel=1e-8)
    assert 0 < sd < 0.05
    # the reference side (its noise taken as smooth) is diluted by 1 / (1 + x)
    assert sides["ref"][0] == pytest.approx(g / (1 + x), rel=1e-9)


def _draw(rng, reps, g, x, noise_u, k):
    """Band sums of ``reps`` records, ``k`` complex samples a band (unit
    mean ground per sample, scaled by GROUND)."""
    shape = (reps, GROUND.size, k)

    def cn(var):
        return np.sqrt(var / 2)[None, :, None] * (rng.standard_normal(shape)
                                                  + 1j * rng.standard_normal(shape))
    s, nr, nu = cn(GROUND / k), cn(x * GROUND / k), cn(noise_u / k)
    xx, yy = s + nr, g * s + nu
    return (np.sum(np.abs(xx) ** 2, axis=2), np.sum(yy * xx.conj(), axis=2),
            np.sum(np.abs(yy) ** 2, axis=2))


def test_standard_errors_match_the_scatter_of_simulated_records():
    """The standard errors of both bounds, of the SUT-side gain and of the
    two sides' difference against their scatter over simulated records (the
    sd of 1500 draws is known to about 2 %, tolerance 8 %; of 500 draws to
    about 3 %, tolerance 12 %)."""
    rng = np.random.default_rng(7)
    g, x, k = 1.02, 0.2, 64
    noise_u = 0.3 * SMOOTH @ np.array([1.0, 1.0])
    a, c, y = _draw(rng, 1500, g, x, noise_u, k)
    dof = np.full(GROUND.size, float(k))
    est = np.array([gb.bounds(a[i], c[i], y[i], dof) for i in range(a.shape[0])])
    sides = [gb.side_gains(a[i], c[i], y[i], dof, SMOOTH, SMOOTH) for i in range(500)]
    side = np.array([[*s["sut"], *s["ref"], s["difference"], s["difference_sd"]] for s in sides])
    for value, sd in ((est[:, 0], est[:, 2]), (est[:, 1], est[:, 3])):
        assert np.std(value, ddof=1) == pytest.approx(np.median(sd), rel=0.08)
    for value, sd in ((side[:, 0], side[:, 1]), (side[:, 4], side[:, 5])):   # 500 records
        assert np.std(value, ddof=1) == pytest.approx(np.median(sd), rel=0.12)
    assert abs(np.mean(side[:, 0]) - g) < 4 * np.median(side[:, 1]) / np.sqrt(500)


@pytest.mark.parametrize("end, x, sut_noise, seed", [
    ("lower", 0.0, 0.3, 21),        # a quiet reference: the lower bound is the gain
    ("upper", 0.2, 0.0, 22),        # a quiet SUT: the upper bound is the gain
])
def test_each_end_of_the_interval95_misses_the_gain_in_its_share(end, x, sut_noise, seed):
    """Each end of ``interval95`` on its own, where its bound equals the
    gain (the other sensor's noise zero): the end passes the gain in 2.5 %
    of 2000 simulated records, within the binomial 99.9 % range."""
    from scipy.stats import binom
    rng = np.random.default_rng(seed)
    g, k, n = 1.02, 64, 2000
    a, c, y = _draw(rng, n, g, x, sut_noise * SMOOTH @ np.array([1.0, 1.0]), k)
    dof = np.full(GROUND.size, float(k))
    ends = np.array([gb.channel_entry(gb.bounds(a[i], c[i], y[i], dof), None, g, 0.01)
                     ["interval95"] for i in range(n)])
    misses = np.sum(ends[:, 0] > g) if end == "lower" else np.sum(ends[:, 1] < g)
    lo, hi = binom.ppf([0.0005, 0.9995], n, 0.025)
    assert lo <= misses <= hi, (end, misses, lo, hi)


def test_side_gains_not_checked_only_where_the_spectra_are_not_finite():
    """Shapes that are not finite leave the gain not checked (None); a
    coding error (shapes of the wrong number of bands) is raised, not read
    as "not checked"."""
    a, c, y = _sums(1.04, 0.25, SMOOTH @ np.array([2.0, 1.0]))
    bad = SMOOTH.copy()
    bad[3, 1] = np.nan
    assert gb._sides_or_none(a, c, y, DOF, bad, SMOOTH) is None
    assert gb._sides_or_none(a, c, y, DOF, SMOOTH, SMOOTH)["sut"][0] == pytest.approx(1.04)
    with pytest.raises(ValueError):
        gb._sides_or_none(a, c, y, DOF, SMOOTH[:-1], SMOOTH)


def _sides(g_u, sd_u, diff, diff_sd):
    return {"sut": (g_u, sd_u), "ref": (g_u - diff, sd_u), "fraction": 0.0,
            "difference": diff, "difference_sd": diff_sd}


def test_verdict_rules():
    # bounds within the fit's uncertainty: separable whatever the sides say
    assert gb.separation_verdict(1.0, 0.01, 0.995, 1.01, None)
    # the sides agree, and the SUT's can tell the ends of the bounds apart
    assert gb.separation_verdict(1.0, 0.005, 0.9, 1.1, _sides(1.004, 0.004, 0.004, 0.002))
    # the sides disagree by 2.6 standard errors of their difference
    assert not gb.separation_verdict(1.0, 0.005, 0.9, 1.1, _sides(1.004, 0.004, 0.0052, 0.002))
    # the fit disagrees with the SUT's side
    assert not gb.separation_verdict(0.91, 0.005, 0.9, 1.1, _sides(1.0, 0.004, 0.0, 0.002))
    # the SUT's side cannot tell the ends apart, or is missing
    assert not gb.separation_verdict(1.0, 0.005, 0.95, 1.05, _sides(1.0, 0.02, 0.0, 0.01))
    assert not gb.separation_verdict(1.0, 0.005, 0.95, 1.05, None)


def _pair(sut_counts, ref_coherence, seed=11):
    from bayescal.simulate import simulate_pair
    gains = (1.02, 0.98, 1.01)
    kw = dict(duration=1800.0, fs=10.0, seed=seed, coherence=0.99, ref_coherence=ref_coherence,
              sut_azimuth=(30.0, 120.0, 0.0), nominal_azimuth=(30.0, 120.0, 0.0),
              nominal_response=(30.0, 0.707, 750.0),
              sut_response=tuple((30.0, 0.707, 750.0 * g) for g in gains))
    sut = simulate_pair(noise_in_counts=sut_counts, **kw)
    ref = sut if sut_counts is False else simulate_pair(noise_in_counts=False, **kw)
    return sut, ref, gains


def _fit(sut, ref):
    import bayescal
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bayescal.calibrate(ref=ref.ref, ref_xml=ref.ref_inventory, sut=sut.sut,
                                 sut_xml=sut.sut_inventory, band=(0.02, 1.0), progress=False,
                                 diagnose=False, min_ess=100, n_tau=10)
    return res.summary()


def test_ground_shaped_noise_is_flagged_with_the_truth_in_its_bounds():
    """Both sensors' noise shaped like the ground, the reference's 11 % of
    the ground power: the fit's gains lean about 10 % low, every gain is
    flagged with the truth inside its bounds, and the console says so with
    the remedy."""
    from bayescal.cli.fit import _print_notes
    sut, ref, gains = _pair(False, 0.9)
    summary = _fit(sut, ref)
    entry = summary["meta"]["reference_noise"]["gain_bounds"]
    for (cid, e), g in zip(entry["channels"].items(), gains):
        assert e["fit"] < 0.95 * g, cid           # diluted by 1 / (1 + x), x = 0.11
        assert not e["separable"], cid
        assert e["interval95"][0] <= g <= e["interval95"][1], cid
    out = io.StringIO()
    _print_notes(summary, out)
    text = out.getvalue()
    assert "not separable" in text and "bayescal noise" in text and "--ref-noise-psd" in text


def test_sut_noise_white_in_counts_identifies_the_gain():
    """The reference's noise shaped like the ground (11 %), the SUT's white
    in counts: the SUT-side gain holds the truth (within 3.5 sd) where the
    fit's gains lean low, and the fit is flagged."""
    sut, ref, gains = _pair(True, 0.9)
    entry = _fit(sut, ref)["meta"]["reference_noise"]["gain_bounds"]
    for (cid, e), g in zip(entry["channels"].items(), gains):
        su = e["sut_side"]
        assert abs(su["gain"] - g) <= 3.5 * su["sd"], (cid, su, g)
        assert su["reference_noise_fraction"] == pytest.approx(0.11, abs=0.05)
        assert not e["separable"]
