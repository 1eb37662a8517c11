"""Self-noise of both sensors from a pair fit (bayescal.core.selfnoise.pair_noise) and
the swapped-sensors warning: the estimators exact at the expected matrix,
the intervals holding the simulation's true noise at their rate, and the
reference-minus-SUT margin against its expected value given the truth."""
import io
import json
import os

import numpy as np
import pytest

from bayescal.core.selfnoise import pair_noise
from bayescal.pair.workflow import calibrate
from bayescal.io.result import write_results
from bayescal.simulate.harness import band_noise_truth
from bayescal.simulate.pair import simulate_pair
from tests.fitting import fit_pair, fit_sim

SIM = dict(duration=3600.0, fs=10.0)


def _expected(t, s_ss, n_u, n_r):
    """Expected band matrix of the model SUT = T s + n_u, ref = s + n_r."""
    nu = t.shape[0]
    top = np.concatenate([t @ s_ss @ t.conj().T + np.diag(n_u), t @ s_ss], axis=1)
    bot = np.concatenate([s_ss @ t.conj().T, s_ss + np.diag(n_r)], axis=1)
    return np.concatenate([top, bot], axis=0)


@pytest.mark.parametrize("nu,nr", [(3, 3), (2, 2), (3, 2)])
def test_forms_exact_at_the_expected_matrix(nu, nr):
    """At the expected matrix the two linear forms return the true noises
    exactly (square and non-square T); the form diag(S_uu - T S_rr T^H),
    also linear, is off by diag(T N_r T^H)."""
    rng = np.random.default_rng(1)
    t = rng.normal(size=(nu, nr)) + 0.1j * rng.normal(size=(nu, nr))
    a = rng.normal(size=(nr, nr)) + 1j * rng.normal(size=(nr, nr))
    s_ss = a @ a.conj().T + np.eye(nr)
    n_u, n_r = rng.uniform(0.1, 1, nu), rng.uniform(0.1, 1, nr)
    c = _expected(t, s_ss, n_u, n_r)
    eu, er = pair_noise.noise_from_t(c, t)
    np.testing.assert_allclose(eu, n_u, rtol=1e-10)
    np.testing.assert_allclose(er, n_r, rtol=1e-10)
    naive = np.real(np.diag(c[:nu, :nu] - t @ c[nu:, nu:] @ t.conj().T))
    np.testing.assert_allclose(n_u - naive, np.real(np.diag(t @ np.diag(n_r) @ t.conj().T)),
                               rtol=1e-10)


def test_fewer_sut_channels_leave_reference_unidentified():
    rng = np.random.default_rng(2)
    t = rng.normal(size=(2, 3))
    c = _expected(t, np.eye(3) * 5, np.full(2, 0.3), np.full(3, 0.2))
    eu, er = pair_noise.noise_from_t(c, t)
    np.testing.assert_allclose(eu, 0.3, rtol=1e-10)
    assert np.isnan(er).all()


#: Pairs per arm of the coverage test (seeds fixed before any result).
N_NOISE_PAIRS = 8


def _pair_level_test(values, expected, alpha):
    """Two-sided one-sample t statistic of per-pair values against their
    expected mean, and the bound it must stay within (pairs are the
    independent units: checks within one pair share its transfer estimate
    and its spectra)."""
    from scipy.stats import t as student
    v = np.asarray(values, float)
    with np.errstate(divide="ignore", invalid="ignore"):   # no spread: any offset is infinite
        stat = (v.mean() - expected) / (v.std(ddof=1) / np.sqrt(v.size))
    stat = 0.0 if np.isnan(stat) else stat
    return stat, float(student.isf(alpha / 2, v.size - 1))


@pytest.mark.parametrize("arm", ["gains held", "default, noise white in counts"])
def test_interval_covers_known_self_noise(arm):
    """Both sensors noisy (coherence 0.99 each): the true self-noise of all
    six channels in every band against its 90 % interval. ``gains held``:
    gains at their (true) metadata values, noise a share of each channel's
    signal. ``default``: the default fit (gains free, --ref-noise estimate)
    with self-noise white in counts, the shape its noise model holds (with
    noise shaped like the ground it is known to under-cover: README).

    The units are the 8 pairs (the 48 checks of one pair share its transfer
    estimate and spectra, so they are not independent): a one-sample t-test
    over pairs of each pair's fraction inside (expected 0.9) and of its mean
    squared standardised error ((estimate - truth) / sd, expected 1), each at
    level 0.0005 (0.001 for the test). Its power on these very fits is
    checked too: the same intervals made 1.5 times narrower or wider must
    fail it."""
    seeds = {"gains held": range(21, 21 + N_NOISE_PAIRS),
             "default, noise white in counts": range(31, 31 + N_NOISE_PAIRS)}[arm]
    held = arm == "gains held"
    per_pair = []
    for seed in seeds:
        kw = dict(SIM, seed=seed, coherence=0.99, ref_coherence=0.99, noise_in_counts=not held)
        p = simulate_pair(**kw)
        post = fit_sim(p, band=(0.02, 1.0), progress=False,
                       **({"fit_response": "none"} if held else {}))
        sp = post.state.model.spectra
        truth = band_noise_truth(sp, kw)
        r = pair_noise.pair_self_noise(post.state.model, np.median(post.state.full_samples, axis=0),
                                       post.state.full_samples)
        per_pair.append((r["psd"], r["sd"], truth))
        # result.json carries the same numbers in dB for every channel of both sensors
        entry = post.self_noise["channels"]
        assert set(entry) == set(sp.sut_ids) | set(sp.ref_ids)
        assert len(entry[sp.ref_ids[0]]["ci90_db"][0]) == sp.n_bands
    z90 = 1.6449

    def verdict(scale):
        rate = [np.mean(np.abs(psd - t) <= z90 * sd * scale) for psd, sd, t in per_pair]
        msq = [np.mean(((psd - t) / (sd * scale)) ** 2) for psd, sd, t in per_pair]
        (t_rate, bound), (t_msq, _) = (_pair_level_test(rate, 0.9, 0.0005),
                                       _pair_level_test(msq, 1.0, 0.0005))
        return abs(t_rate) <= bound and abs(t_msq) <= bound, (rate, msq, t_rate, t_msq, bound)

    ok, info = verdict(1.0)
    assert ok, info
    for scale in (1 / 1.5, 1.5):
        assert not verdict(scale)[0], (scale, verdict(scale)[1])


def _fit(coherence, ref_coherence, seed=3):
    p = simulate_pair(**SIM, seed=seed, coherence=coherence, ref_coherence=ref_coherence)
    return fit_sim(p, band=(0.02, 1.0), progress=False, fit_response="none")


def _margin_range(post, kw, n=20000, seed=0):
    """The 0.05 and 99.95 % points of the reference-minus-SUT margin
    statistic (median over bands and channel pairs of the dB difference of
    the two estimates, bands where both are positive) when each estimate is
    the simulation's true noise plus a normal error of the fit's stated
    standard error, and the true margin: what the statistic is expected to
    read given the truth."""
    sp = post.state.model.spectra
    truth = band_noise_truth(sp, kw)[list(range(sp.n_u)) + [3 + k for k in range(sp.n_r)]]
    theta = np.median(post.state.full_samples, axis=0)
    res = pair_noise.pair_self_noise(post.state.model, theta, post.state.full_samples)
    along = list(np.argmax(np.abs(pair_noise.transfer(post.state.model, theta)[0][0, 0]), axis=0))
    est = truth[None] + res["sd"][None] * np.random.default_rng(seed).standard_normal(
        (n,) + truth.shape)
    ref, sut = est[:, sp.n_u:], est[:, along]
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where((ref > 0) & (sut > 0), 10 * np.log10(ref) - 10 * np.log10(sut), np.nan)
    stat = np.nanmedian(d.reshape(n, -1), axis=1)
    true_db = float(np.median(10 * np.log10(truth[sp.n_u:] / truth[along])))
    return np.percentile(stat, [0.05, 99.95]), true_db


def test_swapped_sensors_are_named(tmp_path):
    """A reference 20.5 dB noisier than the SUT (coherence 0.9 against 0.999,
    noise-to-signal 0.111 against 0.001: the sensors given the wrong way
    round) is said in result.json, the console summary and page 1 of the
    report. The margin statistic understates the true 20.5 dB, as it must:
    the quiet sensor's estimate is limited by the noisy one's (error ~
    sqrt(S N_r / dof)), so its expected reading given the truth and the
    estimates' standard errors is about 10 dB; the margin must lie within
    that reading's 99.9 % range and above the 3 dB threshold."""
    from bayescal.cli.fit import print_summary
    from bayescal.report.fit import write_report

    post = _fit(0.999, 0.9)
    order = post.sensor_order
    assert order["reference_noisier"] is True
    (lo, hi), true_db = _margin_range(post, dict(SIM, seed=3, coherence=0.999, ref_coherence=0.9))
    assert true_db == pytest.approx(10 * np.log10((0.1 / 0.9) / (0.001 / 0.999)), abs=1e-6)
    assert pair_noise.SWAP_MARGIN_DB < lo <= order["reference_minus_sut_db"] <= hi < true_db, \
        (order["reference_minus_sut_db"], lo, hi, true_db)
    write_results(post, tmp_path)
    with open(os.path.join(tmp_path, "result.json")) as fh:
        saved = json.load(fh)
    assert "were --ref and --sut swapped?" in saved["sensor_order"]["message"]
    out = io.StringIO()
    print_summary(saved, out)
    assert "the reference is noisier than the sensor under test by" in out.getvalue()
    written = write_report(str(tmp_path), png=True)
    assert any(p.endswith("report_self_noise.png") for p in written)
    from pypdf import PdfReader
    page1 = PdfReader(written[0]).pages[0].extract_text()
    assert "were --ref and --sut swapped?" in " ".join(page1.split())


def test_swapped_two_plus_two():
    """Horizontals only on both sides (2+2): both sensors' noise is still
    identified and the swap is still named, the margin within the 99.9 %
    range of its expected reading given the truth (20.5 dB true)."""
    kw = dict(SIM, seed=5, coherence=0.999, ref_coherence=0.9)
    p = simulate_pair(**kw)
    post = fit_pair(p.sut.select(channel="BH[12]"), p.sut_inventory,
                    p.ref.select(channel="BH[NE]"), p.ref_inventory, band=(0.02, 1.0),
                    progress=False, fit_response="none")
    assert len(post.self_noise["channels"]) == 4
    assert all("psd_db" in e for e in post.self_noise["channels"].values())
    assert post.sensor_order["reference_noisier"] is True
    (lo, hi), true_db = _margin_range(post, kw)
    margin = post.sensor_order["reference_minus_sut_db"]
    assert pair_noise.SWAP_MARGIN_DB < margin and lo <= margin <= hi, (margin, lo, hi, true_db)


def test_normal_pair_has_no_swap_message():
    post = _fit(0.9, 0.999)
    assert post.sensor_order["reference_noisier"] is False
    assert post.sensor_order["reference_minus_sut_db"] < -3.0
    assert "message" not in post.sensor_order


@pytest.mark.parametrize("case", ["swapped", "normal", "swapped_below_gain_error",
                                  "sut_gain_low"])
def test_sensor_order_with_free_gains(case):
    """The default fit (gains free, --ref-noise quiet): the fitted gains
    absorb the reference's noise, so the order is judged at the metadata
    gains +-3 %. Judged at the fitted gains instead, the swapped pair gave
    no warning (margin -inf at the fitted gains). ``swapped``: reference
    coherence 0.9 against the SUT's 0.999 (noise 11 % of the signal, over
    the 3 % a gain error can fake): the warning, margin 6.5 dB at seed 3.
    ``normal``: the reverse, silent and determined. ``swapped_below_gain_error``:
    noise 0.5 % of the signal (the demo's levels) with exact metadata: the
    least margin cannot pass, the margin at the metadata gains does: a
    caution naming both readings. ``sut_gain_low``: equal noise (coherence
    0.95), the SUT's true gain 3 % below its metadata: no warning (a gain
    error alone never raises one)."""
    kw = {"swapped": dict(coherence=0.999, ref_coherence=0.9),
          "normal": dict(coherence=0.9, ref_coherence=0.999),
          "swapped_below_gain_error": dict(coherence=0.9999, ref_coherence=0.995),
          "sut_gain_low": dict(coherence=0.95, ref_coherence=0.95,
                               sut_response=((30.0, 0.707, 750 * 0.97),) * 3)}[case]
    p = simulate_pair(**SIM, seed=3, **kw)
    post = calibrate(sut=p.sut, sut_xml=p.sut_inventory, ref=p.ref, ref_xml=p.ref_inventory, band=(0.02, 1.0),
                     progress=False, ref_noise="quiet")
    order = post.sensor_order
    assert "metadata gains" in order["basis"]
    assert "at_fitted_gains_db" not in order
    if case == "swapped":
        assert order["reference_noisier"] is True
        assert 3.0 < order["reference_minus_sut_db"] < 20.5
        assert "were --ref and --sut swapped?" in order["message"]
    else:
        assert order["reference_noisier"] is False
        assert "message" not in order
    if case == "normal":
        assert order["at_metadata_gains_db"] < -3.0
        assert "caution" not in order and "undetermined" not in order
    if case == "swapped_below_gain_error":
        assert order["at_metadata_gains_db"] > 3.0
        assert "swapped or the SUT's gain is below its metadata" in order["caution"]
    if case == "sut_gain_low":
        assert "caution" in order or "undetermined" in order


@pytest.mark.parametrize("case", ["swapped_signal_shaped", "swapped_below_gain_error_counts",
                                  "normal_counts"])
def test_sensor_order_default_estimate(case):
    """The default fit (gains free, --ref-noise estimate on 3+3): the
    metadata-gain margins as under quiet, and the margin at the fitted gains,
    unbiased where the self-noise is smooth (white in counts): a swap whose
    noise is only 0.5 % of the signal, which the metadata margins leave at a
    caution, is named (6.7 dB at seed 3; gain sd 0.98 times the quiet
    model's: well separated). With noise shaped like the ground motion the
    fitted gains absorb the reference's noise (-9.6 dB there): the fit says
    the noise is poorly separated from the gains (sd ratio 2.1) and the split
    at the fitted gains is not used; the metadata margins still name the
    swap (6.4 dB)."""
    kw = {"swapped_signal_shaped": dict(coherence=0.999, ref_coherence=0.9),
          "swapped_below_gain_error_counts": dict(coherence=0.9999, ref_coherence=0.995,
                                                  noise_in_counts=True),
          "normal_counts": dict(coherence=0.9, ref_coherence=0.999, noise_in_counts=True)}[case]
    p = simulate_pair(**SIM, seed=3, **kw)
    post = calibrate(sut=p.sut, sut_xml=p.sut_inventory, ref=p.ref, ref_xml=p.ref_inventory, band=(0.02, 1.0),
                     progress=False)
    assert post.meta.reference_noise["mode"] == "estimate"
    assert post.meta.reference_noise["chosen_by"] == "default"
    order = post.sensor_order
    if case == "normal_counts":
        assert order["reference_noisier"] is False and "message" not in order
        assert order["at_fitted_gains_db"] < -3.0 and "caution" not in order
        return
    assert order["reference_noisier"] is True
    assert "were --ref and --sut swapped?" in order["message"]
    separation = post.meta.reference_noise["separation"]
    if case == "swapped_signal_shaped":
        assert "poorly separated" in separation["note"]
        assert "at_fitted_gains_db" not in order and order["reference_minus_sut_db"] > 3.0
    else:
        assert "note" not in separation and max(separation["gain_sd_ratio"].values()) < 1.5
        assert order["reference_minus_sut_db"] < 3.0 < order["at_fitted_gains_db"]


def test_single_component_pair_not_identifiable():
    """A vertical huddle (one channel per sensor): no numbers, the reason."""
    p = simulate_pair(**SIM, seed=4, coherence=0.99, ref_coherence=0.99)
    post = calibrate(sut=p.sut.select(channel="BHZ"), sut_xml=p.sut_inventory, ref=p.ref.select(channel="BHZ"),
                     ref_xml=p.ref_inventory, band=(0.02, 1.0), fit_response="gain", progress=False)
    chans = post.self_noise["channels"]
    assert len(chans) == 2
    for e in chans.values():
        assert e == {"not_identifiable": pair_noise.NOT_IDENTIFIABLE}
    assert "use bayescal noise with a third sensor" in post.self_noise["basis"]
    assert post.sensor_order == {}


def test_unresolved_bands_are_not_left_to_the_resolved_ones():
    """The COWI 11-hour fit's split (dB, three bands): the reference's noise
    is below what the split resolves in the top band, and above the SUT's in
    the lowest only. The median over the bands both resolve reads 3.2 dB (a
    swap warning); counted with the unresolved band for the reference, the
    margin is -0.84 dB (the median of -inf, -inf, -1.34, -0.34, 6.75, 7.06)
    and no swap is suggested. Where most bands are
    unresolved on one side, the resolved bands' median is kept."""
    def p(*v):
        return np.array([10 ** (x / 10) if x is not None else -1.0 for x in v])
    result = {"n_u": 2, "identified": [True] * 4,
              "psd": [p(15.12, 18.11, 21.60), p(12.24, 14.89, 19.36),
                      p(21.87, 16.77, None), p(19.30, 14.55, None)]}
    along = [0, 1]
    assert pair_noise.reference_margin_db(result, along) == pytest.approx(3.2, abs=0.01)
    margin = pair_noise.reference_margin(result, along)
    assert margin == pytest.approx(-0.84, abs=1e-9)
    assert pair_noise.swap_message(margin) is None
    quiet_sut = dict(result, psd=[p(None, None, 1.0), p(None, None, 1.0),
                                  p(20.0, 20.0, 11.0), p(20.0, 20.0, 11.0)])
    assert pair_noise.reference_margin(quiet_sut, along) == pytest.approx(10.0)
    assert "were --ref and --sut swapped?" in pair_noise.swap_message(10.0)
