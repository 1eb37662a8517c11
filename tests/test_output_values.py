"""Values users read in the output files, against the simulated truth (not
their keys):

* the pair fit's self-noise of both sensors in result.json (dB re 1
  (m/s^2)^2/Hz) against the simulation's true noise, per band;
* ``bayescal noise``'s noise.json against the true noise of three
  co-located sensors, per band;
* the corrected StationXML evaluated by ObsPy's evalresp at 10 frequencies
  across the fitted band, amplitude and phase, against the true response
  (period, damping, gain) times the digitizer, for poles in rad/s, the same
  response written in Hertz, and a datalogger with an asymmetric FIR stage;
  its gains in V/(m/s) (stage 1) and counts per m/s (sensitivity);
* a clock offset found by the criticism: the stage delay written equals the
  fitted offset, with the simulator's sign, and the user is told it is a
  time correction of the data that ObsPy's ``remove_response`` does not
  apply.

Each tolerance is derived in its test (Bonferroni or Scheffe bounds at the
suite's level, tests/tolerance.py). Time: about 25 s in all (the clock
offset's fit and criticism, 13 s, most of it).
"""
from __future__ import annotations

import copy
import json
import warnings

import numpy as np
import obspy
import pytest
from scipy.stats import chi2, norm

from tests.tolerance import LEVEL, coverage_band, median_mc_error

#: z of a 90 % central interval (how result.json and noise.json label theirs).
Z90 = float(norm.isf(0.05))


def _bonferroni_z(n_checks):
    """Two-sided normal bound that ``n_checks`` checks all pass with
    probability at least 1 - LEVEL."""
    return float(norm.isf(LEVEL / (2 * n_checks)))


def _power(db_values):
    """dB values (None where the file has null) as linear power (NaN)."""
    return 10 ** (np.array([np.nan if v is None else v for v in db_values], float) / 10)


def _interval_sd(est, lo, hi):
    """The standard deviation a 90 % interval ``[lo, hi]`` states: its width
    over 2 z90 (a normal interval is est +- z90 sd; for noise.json's basic
    bootstrap interval ``[N - q_hi, N - q_lo]`` the width is the spread of
    the estimator's error between its 5 and 95 % points). Where the lower
    bound is null (clipped at zero power), the upper half-width over z90,
    which for result.json's normal interval is the same sd. Taken from the
    bounds, not from the estimate's place between them, so that an estimate
    moved alone is judged by the interval's sd."""
    lo = np.asarray(lo, float)
    return np.where(np.isfinite(lo), (hi - lo) / (2 * Z90), (hi - est) / Z90)


# --- self-noise in result.json ---------------------------------------------------------------
#: Both sensors noisy (coherence 0.9 at 0.2 Hz), noise white in counts: the
#: regime the default fit's noise model holds, so both sensors' noise is
#: identified and every channel can be checked.
PAIR_KW = dict(duration=3600.0, fs=10.0, seed=11, coherence=0.9, ref_coherence=0.9,
               noise_in_counts=True)
PAIR_BAND = (0.02, 1.0)


def test_pair_self_noise_in_result_json_is_the_true_noise(tmp_path):
    """result.json's ``self_noise`` of all six channels, every band, against
    the simulation's true noise per band (band-mean velocity PSD over
    band-mean 1/omega^2, :func:`bayescal.simulate.harness.band_noise_truth`,
    computed from the simulator's noise spectra, not the estimator).

    Tolerance: the file's own 90 % interval (normal on the power scale, its
    sd the Wishart variance of the band spectra plus the scatter over
    posterior draws of T; its coverage is tests/test_pair_noise.py's test)
    gives each band's sd; every estimate must lie within a Bonferroni z
    (level 0.001 over all checks: 4.26 for 48) of those sd (measured: at
    most 2.6). The sd are 4-32 % of the noise here (1/sqrt of the band's
    degrees of freedom times the signal-to-noise factor), so a value 3 dB
    high (twice the power) is up to 25 sd off and fails; so does a
    velocity-to-acceleration conversion off by 2 pi in power (8 dB low) or
    by (2 pi)^2. Band frequencies: the geometric mean of each band's bins."""
    from bayescal.io.result import write_results
    from bayescal.simulate.harness import band_noise_truth
    from bayescal.simulate.pair import simulate_pair
    from tests.fitting import fit_sim

    sim = simulate_pair(**PAIR_KW)
    post = fit_sim(sim, band=PAIR_BAND, progress=False, seed=3)
    write_results(post, str(tmp_path))
    doc = json.loads((tmp_path / "result.json").read_text())["self_noise"]
    assert doc["units"].startswith("dB re 1 (m/s^2)^2/Hz")
    sp = post.state.model.spectra
    truth = band_noise_truth(sp, PAIR_KW)                     # (6, B), SUT then reference
    fc = np.exp(np.bincount(sp.band_of, np.log(sp.freqs)) / sp.bins_per_band)
    z, checked = [], 0
    for j, cid in enumerate(list(sp.sut_ids) + list(sp.ref_ids)):
        e = doc["channels"][cid]
        np.testing.assert_allclose(e["freq_hz"], fc, rtol=1e-9)
        est = _power(e["psd_db"])
        lo, hi = _power(e["ci90_db"][0]), _power(e["ci90_db"][1])
        sd = _interval_sd(est, lo, hi)
        assert np.all(np.isfinite(est)) and np.all(sd > 0), (cid, e)
        # the interval is what its label and units text state: est +- z90 sd_psd on the
        # power scale, a bound not above zero written as null (float rounding only)
        sd_file = np.asarray(e["sd_psd"], float)
        for bound, written in ((est - Z90 * sd_file, lo), (est + Z90 * sd_file, hi)):
            assert np.array_equal(bound > 0, np.isfinite(written)), (cid, bound, written)
            np.testing.assert_allclose(written[bound > 0], bound[bound > 0], rtol=1e-6)
        z.append((est - truth[j]) / sd)
        checked += est.size
    z = np.array(z)
    bound = _bonferroni_z(checked)
    assert checked == 6 * sp.n_bands and np.max(np.abs(z)) <= bound, (np.round(z, 2), bound)


# --- noise.json -------------------------------------------------------------------------------
def test_noise_json_is_the_true_noise(tmp_path):
    """``bayescal noise`` on three simulated co-located sensors
    (:mod:`bayescal.simulate.selfnoise`: noise white in acceleration at -185
    dB, white in velocity, white in counts; 1800 s at 20 Hz): noise.json's
    ``psd_db`` per band against each sensor's true band noise
    (:func:`bayescal.simulate.selfnoise.true_band_noise`, from the
    simulator's noise spectra), at every band whose interval the file
    bounds below (elsewhere the sensor is below resolution and only the
    upper bound is a result: the truth must lie under it).

    Tolerance: the file's own 90 % interval (basic bootstrap on the power
    scale, :func:`_interval_sd`; it holds the truth at its rate in
    tests/test_selfnoise.py) gives each band's sd, and every estimate must
    lie within a Bonferroni z over the checks (level 0.001: 4.32 for 64;
    measured: at most 2.05) of those sd, plus the file's rounding to 0.01
    dB. Its sd are 2.5-30 % of the noise at short periods, so a value 3 dB
    high fails (up to 39 sd off), and so does a 2 pi unit error."""
    from bayescal.cli import main
    from bayescal.simulate.selfnoise import estimate_and_truth, simulate_colocated

    sim = simulate_colocated(duration=1800.0, fs=20.0, seed=3)
    data, xml = sim.write(str(tmp_path / "in"))
    out = tmp_path / "out"
    assert main(["noise", "--data", *data, "--xml", *xml, "--out", str(out), "--n-boot", "300",
                 "--quiet", "--no-report"]) == 0
    doc = json.loads((out / "noise.json").read_text())
    assert doc["meta"]["units"] == "dB re 1 (m/s^2)^2/Hz"
    # the true band noise on the same bands (same band, segments and band rule as the CLI)
    est, truth, _ = estimate_and_truth(sim, band=tuple(doc["meta"]["band_hz"]), n_boot=2)
    order = np.argsort(1 / est.freqs)                          # noise.json: by increasing period
    z, upper = [], []
    for i, cid in enumerate(f"XS.SIM.{loc}.BHZ" for loc in ("00", "10", "60")):
        e = doc["sensors"][cid]
        np.testing.assert_allclose(e["period_s"], 1 / est.freqs[order], rtol=1e-4)
        t = truth[i][order]
        val, lo, hi = _power(e["psd_db"]), _power(e["ci90_db"][0]), _power(e["ci90_db"][1])
        bounded = np.isfinite(lo) & np.isfinite(val)
        assert bounded.sum() >= 10, (cid, e["ci90_db"])
        # |error| less the file's rounding (0.005 dB), in sd
        off = np.abs(val - t) - val * (10 ** 0.0005 - 1)
        z.append(off[bounded] / _interval_sd(val, lo, hi)[bounded])
        upper.append((t <= hi)[~bounded & np.isfinite(hi)])
    z = np.concatenate(z)
    bound = _bonferroni_z(z.size)
    assert np.max(z) <= bound, (np.round(z, 2), bound)
    # below resolution, the upper end of the 90 % interval is a 95 % one-sided bound:
    # the count holding the truth within the binomial band of tests/tolerance.py
    upper = np.concatenate(upper)
    assert upper.sum() >= coverage_band(upper.size, 0.95)[0], upper


# --- corrected StationXML ---------------------------------------------------------------------
#: The SUT's true vertical: (period s, damping, gain V/(m/s)); metadata 30 s, 0.707, 750.
TRUE_Z = (27.0, 0.68, 780.0)
XML_BAND = (0.03, 1.0)
#: The datalogger's FIR: input rate (Hz), decimation, and an asymmetric
#: (minimum-phase-like) low-pass, its delay at DC corrected by the stage.
FIR_RATE, FIR_DECIMATION = 40.0, 4
FIR = np.exp(-np.arange(12) / 2.5)
FIR = FIR / FIR.sum()
FIR_DELAY = float(np.sum(np.arange(FIR.size) * FIR) / FIR_RATE)


def _analog(f, period, damping, gain, norm_freq=1.0):
    """The true velocity response of stage 1 (V per m/s), written out here:
    ``G s^2 / (s^2 + 2 h w0 s + w0^2)`` normalised to ``G`` at ``norm_freq``,
    ``s = 2 pi i f``; broadcasts over parameter arrays (..., 1)."""
    w0 = 2 * np.pi / np.asarray(period)

    def paz(s):
        return s * s / (s * s + 2 * np.asarray(damping) * w0 * s + w0 * w0)
    return np.asarray(gain) * paz(2j * np.pi * np.asarray(f)) / np.abs(paz(2j * np.pi * norm_freq))


def _fir(f):
    """The FIR stage as the datalogger applies it: ``sum c_k exp(-i w k dt)``
    with the corrected delay added back, ``exp(+i w delay)``."""
    w = 2 * np.pi * np.asarray(f, float)
    k = np.arange(FIR.size)
    return (np.exp(-1j * np.outer(w, k) / FIR_RATE) @ FIR) * np.exp(1j * w * FIR_DELAY)


def _hertz(inv):
    """The same inventory with every stage-1 poles and zeros written as
    LAPLACE (HERTZ): poles and zeros divided by 2 pi, the normalization
    factor recomputed to 1 / |H(i f_n)| in Hertz."""
    inv = copy.deepcopy(inv)
    for ch in inv[0][0]:
        st = ch.response.response_stages[0]
        st.pz_transfer_function_type = "LAPLACE (HERTZ)"
        st.zeros = [complex(z) / (2 * np.pi) for z in st.zeros]
        st.poles = [complex(p) / (2 * np.pi) for p in st.poles]
        s = 1j * st.normalization_frequency
        st.normalization_factor = float(1 / abs(np.prod([s - z for z in st.zeros])
                                                / np.prod([s - p for p in st.poles])))
    return inv


def _with_fir(inv):
    """The same inventory with a datalogger of two digital stages: the
    digitizer's gain stage at ``FIR_RATE`` and the asymmetric FIR decimating
    by ``FIR_DECIMATION``, its delay corrected."""
    from obspy.core.inventory.response import FIRResponseStage
    from obspy.core.inventory.util import Frequency

    inv = copy.deepcopy(inv)
    for ch in inv[0][0]:
        resp = ch.response
        resp.response_stages[1].decimation_input_sample_rate = Frequency(FIR_RATE)
        resp.response_stages.append(FIRResponseStage(
            stage_sequence_number=3, stage_gain=1.0, stage_gain_frequency=1.0,
            input_units="COUNTS", output_units="COUNTS", symmetry="NONE",
            coefficients=list(FIR), decimation_input_sample_rate=FIR_RATE,
            decimation_factor=FIR_DECIMATION, decimation_offset=0,
            decimation_delay=FIR_DELAY, decimation_correction=FIR_DELAY))
    return inv


def _filtered(stream, response):
    """``stream`` through the frequency response ``response(f)`` (the
    simulated records are periodic, so one FFT applies it exactly)."""
    out = stream.copy()
    for tr in out:
        n = tr.stats.npts
        f = np.fft.rfftfreq(n, tr.stats.delta)
        tr.data = np.fft.irfft(np.fft.rfft(tr.data) * response(f), n=n)
    return out


@pytest.fixture(scope="module")
def true_z_pair():
    from bayescal.simulate.pair import simulate_pair
    return simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99,
                         sut_response=((30.0, 0.707, 750.0),) * 2 + (TRUE_Z,))


@pytest.mark.parametrize("kind", ["radians", "hertz", "digital"])
def test_corrected_stationxml_response_is_the_true_response(true_z_pair, kind, tmp_path):
    """A ``fit_response="all"`` fit of the vertical (period, damping and gain
    fitted: the written poles move from 30 s to about 27 s), its corrected
    StationXML read back and evaluated by ObsPy's evalresp
    (``get_evalresp_response_for_frequencies``, velocity) at 10 log-spaced
    frequencies across the fitted band, against the true response (written
    out in :func:`_analog`) times the digitizer's 4e5 counts/V, times the
    FIR for ``digital``. ``radians``: the simulator's metadata (LAPLACE
    (RADIANS/SECOND)); ``hertz``: the same response in LAPLACE (HERTZ),
    fitted and written in Hertz; ``digital``: a datalogger with an
    asymmetric FIR after the digitizer (the recordings made through it).

    Tolerance: the written values are the posterior medians; with the truth
    a draw from the posterior (its coverage is tested elsewhere), each
    response value's error is, to first order, a linear function of the
    three parameters' error, so all of them (10 log-amplitudes, 10 phases,
    both gains) hold together within Scheffe's bound
    sqrt(chi2_3(1 - 0.001/3)) = 4.31 of their posterior sd (3: one bound
    per fit), each sd taken over the posterior samples, widened by the Monte
    Carlo error of a median (1.25 sd / sqrt(ESS); 4.41 in all at ESS 2900),
    plus 1e-9 for float rounding (StationXML keeps 17 digits). Measured: at
    most 1.05 sd in amplitude, 0.89 sd in phase, 0.59 sd in gain. The
    sensitivity over the stage-1 gain is fixed by the metadata alone:
    digitizer gain times the FIR's amplitude at the sensitivity frequency
    (1 Hz, where stage 1 is normalised), to float rounding.

    Breakages this catches: a Hertz stage's poles written in rad/s (period
    2 pi off: amplitude 440-620 sd off at the low end), a sensitivity taken
    as the product of the stage gains (the FIR's 1 Hz amplitude, 0.94, left
    out), and a normalization factor left at its nominal value when the
    poles move."""
    from bayescal.simulate.pair import DIGITIZER_GAIN
    from tests.fitting import fit_pair

    sim = true_z_pair
    inv = {"radians": sim.sut_inventory, "hertz": _hertz(sim.sut_inventory),
           "digital": _with_fir(sim.sut_inventory)}[kind]
    sut = sim.sut.select(channel="BHZ")
    digital = (lambda f: DIGITIZER_GAIN * _fir(f)) if kind == "digital" else \
        (lambda f: DIGITIZER_GAIN + 0j * np.asarray(f))
    if kind == "digital":
        sut = _filtered(sut, _fir)
    post = fit_pair(sut, inv, sim.ref, sim.ref_inventory, band=XML_BAND, fit_response="all",
                    progress=False)
    from bayescal.io.stationxml import write_corrected
    write_corrected(inv, post, tmp_path / "c.xml")
    resp = obspy.read_inventory(str(tmp_path / "c.xml")).select(channel="BHZ")[0][0][0].response
    stage = resp.response_stages[0]
    assert stage.pz_transfer_function_type == inv.select(channel="BHZ")[0][0][0].response \
        .response_stages[0].pz_transfer_function_type
    f = np.geomspace(*XML_BAND, 10)
    written = resp.get_evalresp_response_for_frequencies(f, output="VEL")
    truth = _analog(f, *TRUE_Z) * digital(f)
    # posterior sd of each value: over the samples, relative to the median's
    samples = post.response["XX.SIM.10.BHZ"]
    med = np.median(samples, axis=0)
    rel = _analog(f, *(samples[:, k:k + 1] for k in range(3))) / _analog(f, *med)
    sd_amp, sd_phase = np.std(np.log(np.abs(rel)), axis=0), np.std(np.angle(rel), axis=0)
    ess = post.summary()["convergence"]["ess_min"]
    k = np.sqrt(chi2.isf(LEVEL / 3, 3)) * (1 + median_mc_error({"sd": 1.0}, ess))
    d_amp, d_phase = np.log(np.abs(written / truth)), np.angle(written / truth)
    assert np.all(np.abs(d_amp) <= k * sd_amp + 1e-9), (kind, d_amp / sd_amp, k)
    assert np.all(np.abs(d_phase) <= k * sd_phase + 1e-9), (kind, d_phase / sd_phase, k)
    # gains: stage 1 in V/(m/s), the sensitivity in counts per m/s at 1 Hz
    assert str(stage.input_units).upper() == "M/S" and str(stage.output_units).upper() == "V"
    sd_gain = np.std(samples[:, 2])
    assert abs(stage.stage_gain - TRUE_Z[2]) <= k * sd_gain + 1e-9 * TRUE_Z[2]
    sens = resp.instrument_sensitivity
    assert sens.frequency == 1.0 and str(sens.input_units).upper() == "M/S"
    assert abs(sens.value - abs(truth[-1])) <= (k * sd_gain / med[2] + 1e-9) * abs(truth[-1])
    assert sens.value / stage.stage_gain == pytest.approx(abs(digital(1.0)), rel=1e-9)


# --- clock offset -----------------------------------------------------------------------------
#: The SUT's samples are this late (the simulator delays its spectra by
#: exp(-2 pi i f tau): each arrival shows this much later on the SUT).
LATE_S = 0.2


def _last_decimating(response):
    """The last stage of ``response`` with decimation fields (the digitizer's
    output, where the offset is written)."""
    return [s for s in response.response_stages if s.decimation_input_sample_rate][-1]


def test_clock_offset_is_written_as_fitted_and_told_as_a_time_correction(tmp_path):
    """SUT samples 0.2 s late, found by the fit's criticism: the corrected
    StationXML's digitizer stage delay is the original delay plus the fitted
    offset's median, to float rounding, with the simulator's sign (+ = the
    SUT's samples late, the StationXML sense of a delay: a delayed signal);
    the fitted offset holds the truth in its 95 % interval. ObsPy's evalresp
    gives the same response with or without that delay (which is why the
    user is told): the console's advice, the channel's comment and
    docs/fit.md say that a clock offset is a time correction of the data,
    not a response change that ``remove_response`` applies, and the comment
    gives the shift of the start times (minus the offset)."""
    import bayescal
    from bayescal.criticism.verdict import lines
    from bayescal.io.result import write_results
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=10.0, seed=31, coherence=0.99,
                        sut_azimuth=(20.0, 110.0, 0.0), nominal_azimuth=(18.0, 108.0, 0.0),
                        timing_offset_s=LATE_S)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                                  sut_xml=sim.sut_inventory, band=(0.03, 2.0), progress=False,
                                  min_ess=200, n_tau=20)
    c = post.summary()["criticism"]
    (effect,) = [e for e in c["effects"] if e["name"] == "timing_offset"]
    tau = effect["size"]["seconds"]
    assert tau["ci95"][0] <= LATE_S <= tau["ci95"][1] and tau["median"] > 0
    write_results(post, str(tmp_path))
    back = obspy.read_inventory(str(tmp_path / "sut_corrected.xml"))
    f = np.geomspace(0.03, 2.0, 10)
    for tr in sim.sut:
        ch = back.select(channel=tr.stats.channel)[0][0][0]
        orig = sim.sut_inventory.select(channel=tr.stats.channel)[0][0][0]
        stage, before = _last_decimating(ch.response), _last_decimating(orig.response)
        assert stage.decimation_delay == pytest.approx(before.decimation_delay + tau["median"],
                                                       rel=1e-12, abs=1e-15)
        assert stage.decimation_correction == before.decimation_correction
        # what remove_response evaluates does not see the delay
        undone = copy.deepcopy(ch.response)
        _last_decimating(undone).decimation_delay = before.decimation_delay
        np.testing.assert_array_equal(
            ch.response.get_evalresp_response_for_frequencies(f, output="VEL"),
            undone.get_evalresp_response_for_frequencies(f, output="VEL"))
        text = " ".join(x.value for x in ch.comments if x.subject == "bayescal criticism")
        assert "time correction of the data, not a response change" in text, text
        assert "remove_response does not apply" in text, text
        assert f"shift the SUT's start times by {-tau['median']:+.6g} s" in text, text
    console = "\n".join(lines(c))
    assert "a clock offset is a time correction of the data" in console, console
    assert "remove_response does not apply" in console, console
    assert f"start time by {-tau['median']:+.3g} s" in console, console
    from pathlib import Path
    docs = " ".join((Path(__file__).parents[1] / "docs" / "fit.md").read_text().split())
    assert "is a time correction of the data, not a response change" in docs
    assert "`remove_response` never reads a stage's delay" in docs


@pytest.mark.parametrize("offset", [0.2, -0.2])
def test_clock_advice_shifts_the_start_times_against_the_offset(offset):
    """The console's advice for a timing offset gives the signed shift of
    the SUT's start times: minus the offset (samples 0.2 s late: -0.2 s;
    0.2 s early: +0.2 s), whichever way the clock is off."""
    from bayescal.criticism.words import advice as _advice

    text = _advice({"name": "timing_offset", "parameters": {"seconds": {"median": offset}}})
    assert f"shift each SUT trace's start time by {-offset:+.3g} s" in text, text
