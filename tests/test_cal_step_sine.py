"""Step and sine coil calibration (``bayescal cal --kind step|sine``): the
time-domain model against an analytic step response, recovery of simulated
truths (period, damping, gain within 0.5 %; response at the sine's
frequency), the AR noise estimate, and the command end to end."""
from __future__ import annotations

import json

import numpy as np
import pytest
from obspy import read_inventory

from bayescal import cli, coil
from bayescal.coil.hf import PZSpec
from bayescal.coil.sine import fit_sine, sine_frequency
from bayescal.coil.step import StepModel, fit_step, least_squares_step
from bayescal.coil.timedomain import Predictor, ar_fit, coil_transfer, padding
from bayescal.core.response import pendulum
from bayescal.core.response.family import TwoPoleFamily
from bayescal.simulate.cal import simulate_sine_cal, simulate_step_cal
from bayescal.simulate.pair import DIGITIZER_GAIN, NORM_FREQ
from scipy.stats import norm

from tests.tolerance import LEVEL, Z_001

COIL = 1e-9
TRUE_LP = (122.0, 0.69, 1510.0)
FAST = dict(n_walkers=16, min_ess=400)
#: A short step run: 20 minutes at 10 Hz, the step on at 120 s and off at 600 s
#: (the response has decayed 22 times over by the end); period, damping and
#: gain still come out to about 0.05 %, ten times inside the 0.5 % target.
SHORT = dict(duration=1200.0, fs=10.0, steps=((120.0, 1.0), (600.0, 0.0)))


def _run(sim):
    return coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")


def test_step_model_matches_analytic_step_response():
    """For a two-pole sensor (flat digitizer) an acceleration step a gives
    the velocity output G' a e^{-h w0 t} sin(w_d t) / w_d (G' the gain in
    counts per m/s above the corner): the FFT model reproduces it. The
    sampled step is band-limited, so it sits half a sample before its first
    sample and rings at Nyquist for a few samples: the first 2 s after it
    are left out of the comparison."""
    sim = simulate_step_cal(truth=TRUE_LP, noise_ratio=0.0, digitizer_noise=0.0,
                            steps=((100.0, 1.0),), duration=1200.0, fs=10.0)
    run = _run(sim)
    spec = PZSpec.from_response(run.responses[0], "lp", 5.0)
    x, u = run.data[0], run.input
    model = StepModel(x, run.fs, Predictor(u, run.fs, coil_transfer(run, COIL),
                                           padding(spec.family, run.fs)), spec)
    theta = np.r_[pendulum.from_physical(130.0, 0.65, spec.family.period_s, spec.family.damping),
                  np.log(1400.0)]
    got = model.predict(theta)[0]
    w0 = 2 * np.pi / 130.0
    wd = w0 * np.sqrt(1 - 0.65 ** 2)
    sn = 2j * np.pi * NORM_FREQ
    g = 1400.0 * DIGITIZER_GAIN * abs(sn * sn + 2 * 0.65 * w0 * sn + w0 * w0) / abs(sn * sn)
    t = np.arange(x.size) / run.fs - (100.0 - 0.5 / run.fs)
    want = np.where(t >= 0, g * COIL * 1e5 * np.exp(-0.65 * w0 * t) * np.sin(wd * t) / wd, 0.0)
    far = np.abs(t) > 2.0
    np.testing.assert_allclose(got[far], want[far], atol=1e-4 * np.abs(want).max())


def test_ar_fit_recovers_an_ar2_process():
    rng = np.random.default_rng(1)
    e = rng.standard_normal(40000)
    r = np.zeros_like(e)
    for i in range(2, r.size):
        r[i] = 1.2 * r[i - 1] - 0.5 * r[i - 2] + e[i]
    a, s2 = ar_fit(r)
    assert a.size >= 2
    # asymptotic least-squares errors of an AR(2) from N samples: sd of each
    # coefficient sqrt((1 - a2^2) / N) = 0.0043, of the innovation variance
    # sqrt(2 / N) relative = 0.0071; three checks at level 0.001 (3.59 each)
    z3 = float(norm.isf(LEVEL / 6))
    n = r.size
    np.testing.assert_allclose(a[:2], [1.2, -0.5], rtol=0, atol=z3 * np.sqrt((1 - 0.5 ** 2) / n))
    assert s2 == pytest.approx(1.0, rel=z3 * np.sqrt(2.0 / n))


@pytest.mark.parametrize("seed", [31, 32])
def test_step_recovers_period_damping_gain_within_half_a_percent(seed):
    """20-minute step run at 10 Hz, self-noise 1 % of the step's acceleration
    (white, so the output noise is red). The truth is within 3.5 posterior sd
    (fails by chance about once in 2000 per parameter; the 95 % coverage is
    measured in validation/studies/cal_coverage.py)."""
    sim = simulate_step_cal(truth=TRUE_LP, seed=seed, noise_ratio=0.01, **SHORT)
    s = fit_step(_run(sim), COIL, seed=seed, **FAST).summary()
    assert s["kind"] == "step" and s["fit"] == "lp"
    for p, t in zip(("period_s", "damping", "gain"), TRUE_LP):
        e = s["parameters"][p]
        assert abs(e["median"] - t) < 3.5 * e["sd"], (p, e, t)
        assert abs(e["median"] / t - 1) < 0.005, (p, e["median"], t)
    ad = s["adequacy"]
    # the misfit is the mean square of n standardised innovations: 1 with
    # relative sd sqrt(2 / n) where the model fits; Z_001 of it
    assert s["convergence"]["converged"] and ad["ar_order"] >= 1
    assert abs(ad["misfit"] - 1) < Z_001 * np.sqrt(2.0 / ad["n_samples"]), ad


def test_step_with_white_noise_model_would_be_overconfident():
    """The AR noise model matters: the innovation variance is far below the
    raw residual variance (red noise). Least squares only (the sampler's
    start): the noise model is estimated there."""
    sim = simulate_step_cal(truth=TRUE_LP, seed=33, noise_ratio=0.01, **SHORT)
    m, _, theta, _ = least_squares_step(_run(sim), COIL)
    assert m.ar.size >= 1 and m.s2 < 0.2 * np.var(m.raw_residual(theta))


@pytest.mark.parametrize("freq", [0.02, 1.0])
def test_sine_recovers_response_at_its_frequency(freq):
    sim = simulate_sine_cal(freq, truth=TRUE_LP, seed=41, noise_ratio=0.05)
    fit = fit_sine(_run(sim), COIL, **FAST)
    s = fit.summary()
    h = complex(*sim.truth["response"])
    assert s["frequency_hz"] == pytest.approx(sim.truth["sine_freq_hz"], rel=1e-6)
    amp, ph = s["parameters"]["response_amplitude"], s["parameters"]["response_phase_deg"]
    assert abs(amp["median"] - abs(h)) < 3.5 * amp["sd"]
    assert abs(amp["median"] / abs(h) - 1) < 0.005
    assert abs(ph["median"] - np.degrees(np.angle(h))) < 3.5 * ph["sd"]
    # the implied ratio to the nominal
    nom = TwoPoleFamily.from_response(fit.response)
    want = nom.ratio([s["frequency_hz"]], *TRUE_LP)[0, 0]
    r = s["parameters"]["amplitude_ratio"]
    assert abs(r["median"] - abs(want)) < 3.5 * r["sd"]


def test_sine_frequency_and_refusal_of_non_sine():
    t = np.arange(20000) / 20.0
    f, frac = sine_frequency(np.sin(2 * np.pi * 0.1234 * t + 0.3), 20.0)
    assert f == pytest.approx(0.1234, rel=1e-6) and frac > 0.999
    _, frac = sine_frequency(np.sign(np.sin(2 * np.pi * 0.1 * t)) + np.sin(2 * np.pi * 1.7 * t),
                             20.0)
    assert frac < 0.95


# --- the command ---------------------------------------------------------------------

def _cli(tmp, sim, kind, extra=()):
    paths = sim.write(str(tmp / "in"))
    out = tmp / "out"
    rc = cli.main(["cal", "--cal", paths["cal"], "--output-channel", "BHZ", "--sut-xml",
                   paths["xml"], "--coil-constant", str(COIL), "--out", str(out), "--kind", kind,
                   "--quiet", *extra])
    return rc, out


def test_cli_step(tmp_path):
    rc, out = _cli(tmp_path, simulate_step_cal(truth=TRUE_LP, seed=34, noise_ratio=0.01, **SHORT),
                   "step")
    assert rc == 0
    s = json.loads((out / "cal.json").read_text())
    assert s["schema"] == "bayescal.cal/1" and s["kind"] == "step"
    assert set(s["parameters"]) >= {"period_s", "damping", "gain"}
    for name in ("cal_report.pdf", "cal_timeseries.png", "cal_corner.png", "cal_response.png"):
        assert (out / name).exists()
    fam = TwoPoleFamily.from_response(read_inventory(str(out / "sut_corrected.xml"))[0][0][0]
                                      .response)
    assert fam.period_s == pytest.approx(s["parameters"]["period_s"]["median"], rel=1e-9)
    assert fam.period_s == pytest.approx(TRUE_LP[0], rel=0.005)


def _two_pole(f, period_s, damping, gain):
    """Velocity response (V per m/s) of a two-pole pendulum with two zeros at
    the origin, ``gain`` at 1 Hz, written out here (s^2 / (s^2 + 2 h w0 s +
    w0^2), normalised at 1 Hz)."""
    def shape(s):
        w0 = 2 * np.pi / period_s
        return s * s / (s * s + 2 * damping * w0 * s + w0 * w0)
    return gain * shape(2j * np.pi * f) / abs(shape(2j * np.pi * NORM_FREQ))


def test_cli_sine(tmp_path):
    """A 0.5 Hz sine through a sensor whose truth (122 s, 0.69, 1510 V/(m/s))
    differs from its metadata (120 s, 0.707, 1500): the response amplitude
    (counts per m/s), its phase, and the amplitude ratio and phase
    difference against the metadata each lie within 3.29 posterior sd of
    the closed-form values (two-sided level 0.001 each); the amplitude ratio
    (1.0067) lies more than 5 sd from 1, where a fit reporting the metadata
    would put it."""
    rc, out = _cli(tmp_path, simulate_sine_cal(0.5, truth=TRUE_LP, seed=42), "sine")
    assert rc == 0
    s = json.loads((out / "cal.json").read_text())
    assert s["kind"] == "sine" and s["frequency_hz"] == pytest.approx(0.5, rel=1e-6)
    assert {"amplitude_ratio", "phase_difference_deg"} <= set(s["parameters"])
    assert (out / "cal_timeseries.png").exists() and not (out / "sut_corrected.xml").exists()
    true, nominal = _two_pole(0.5, *TRUE_LP), _two_pole(0.5, 120.0, 0.707, 1500.0)
    want = {"response_amplitude": abs(true) * DIGITIZER_GAIN,
            "response_phase_deg": np.degrees(np.angle(true)),
            "amplitude_ratio": abs(true) / abs(nominal),
            "phase_difference_deg": np.degrees(np.angle(true) - np.angle(nominal))}
    for name, value in want.items():
        e = s["parameters"][name]
        assert abs(e["median"] - value) < Z_001 * e["sd"], (name, e, value)
    r = s["parameters"]["amplitude_ratio"]
    assert abs(want["amplitude_ratio"] - 1.0) > 5 * r["sd"], r


@pytest.mark.parametrize("kind, sim, extra, words", [
    ("step", simulate_step_cal(duration=600.0, fs=10.0), ["--fit", "hf"], "--fit lp"),
    ("sine", simulate_sine_cal(0.5, duration=600.0, fs=10.0), ["--fit", "lp"],
     "--fit does not apply"),
    ("sine", simulate_step_cal(duration=600.0, fs=10.0), [], "not a single sine"),
    ("step", simulate_step_cal(duration=600.0, fs=10.0), ["--band", "0.01", "1"],
     "--band does not apply"),
    # the step 2 s (20 samples) before the end: the noise fit had no sample to
    # fit and raised a bare ValueError
    ("step", simulate_step_cal(duration=600.0, fs=10.0, steps=((598.0, 1.0),)), [],
     "2 s (20 samples) before the record ends"),
    ("step", simulate_step_cal(duration=600.0, fs=10.0, steps=((599.0, 1.0),)), [],
     "record longer after it"),
])
def test_cli_bad_input_exit_2_nothing_written(tmp_path, capsys, kind, sim, extra, words):
    rc, out = _cli(tmp_path, sim, kind, extra)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and words in err[0], err
    assert not out.exists()


def _innovation_power_at_truth(seed, slope):
    """Frequencies and periodogram of a short step run's standardised
    innovations at the truth (noise model from its least-squares fit)."""
    sim = simulate_step_cal(truth=TRUE_LP, seed=seed, noise_ratio=0.01, noise_slope=slope,
                            **SHORT)
    m, spec, _, _ = least_squares_step(_run(sim), COIL)
    th = np.r_[pendulum.from_physical(*TRUE_LP[:2], spec.family.period_s, spec.family.damping),
               np.log(TRUE_LP[2])]
    e = m.innovations(th[None])[0]
    return np.fft.rfftfreq(e.size, 1.0 / m.fs), np.abs(np.fft.rfft(e)) ** 2 / e.size



def _band_means(seeds, slope, bands):
    """The innovations' mean power at the truth in each of ``bands`` (Hz),
    pooled over the runs ``seeds`` with self-noise slope ``slope``."""
    power = [[] for _ in bands]
    for seed in seeds:
        f, p = _innovation_power_at_truth(seed, slope)
        for k, (lo, hi) in enumerate(bands):
            power[k].extend(p[(f >= lo) & (f < hi)])
    return [np.mean(q) for q in power]

def test_step_noise_model_right_where_the_information_is():
    """The AR noise model (fitted after the prefilter back to acceleration)
    describes the noise below and just above the pendulum's corner: the
    innovations at the *truth* have their nominal power (1) in 1-5 mHz and
    5-25 mHz, averaged over six 20-minute runs (30 and 144 DFT bins, so
    the means' sd are about 0.18 and 0.08; the bounds are about 3 sd).
    Whitening the counts directly (the AR alone, all poles) gave about 0.2
    and 1.45 here: the output noise has a zero at 0 Hz that an
    autoregression cannot represent (docs/cal.md, "Model (step and sine kinds):
    time domain"; docs/validation/coil.md, "Step and sine runs")."""
    low, mid = _band_means(range(51, 57), 0.0, ((1e-3, 5e-3), (5e-3, 2.5e-2)))
    assert 0.5 < low < 1.6 and 0.75 < mid < 1.25, (low, mid)


# --- the input channel's own noise --------------------------------------------

def test_step_fit_does_not_take_the_input_noise_for_a_drive():
    """A step run whose input channel records 1 % white noise on top of the
    step (the coil felt the clean step): period, damping and gain each
    within Z_001 (the level-0.001 two-sided normal quantile) posterior sd
    of the truth. Driven by the recorded input, the same run's period is
    15 sd off."""
    truth = (121.0, 0.72, 1510.0)
    sim = simulate_step_cal(truth=truth, fs=5.0, noise_ratio=0.01, input_noise=0.01, seed=7)
    p = fit_step(_run(sim), COIL, seed=1, n_walkers=16, min_ess=200).summary()["parameters"]
    for name, t in zip(("period_s", "damping", "gain"), truth):
        z = (p[name]["median"] - t) / p[name]["sd"]
        assert abs(z) < Z_001, (name, z, p[name])


def test_sine_model_is_the_steady_state_response_of_a_cut_sine():
    """A sine of 37.3 cycles cut to the record (not periodic in the FFT
    buffer) through a three-tap filter ``H(f) = sum_k h_k e^{-2 pi i f k / fs}``
    (exact on the FFT grid): after the settling samples the model at
    ``rho = A e^{i phi}`` is the closed form
    ``A |H(f0)| cos(w t + arg H(f0) + phi)`` to 1e-9 of the amplitude.
    The quadrature as ``i`` times the drive's spectrum (the Hilbert
    transform of the cut sine) misses it by 0.14 of the amplitude."""
    from bayescal.coil.sine import SineModel, quadrature_drive
    fs, n, f0, skip = 10.0, 3000, 37.3 / 300.0, 200
    t = np.arange(n) / fs
    drive = np.cos(2 * np.pi * f0 * t)

    def low_pass(f):
        return np.exp(-2j * np.pi * np.outer(f, np.arange(3)) / fs) @ [0.5, 0.3, 0.2]

    model = SineModel(np.zeros(n), fs, Predictor(drive, fs, low_pass, 400), skip,
                      Predictor(quadrature_drive(drive, fs, f0), fs, low_pass, 400))
    a, phi = 0.8, 0.6
    m = model.predict(np.array([np.log(a), phi]))[0]
    h = low_pass(np.array([f0]))[0]
    want = a * abs(h) * np.cos(2 * np.pi * f0 * t + np.angle(h) + phi)
    assert np.max(np.abs(m - want)[skip:]) < 1e-9 * a * abs(h)


def test_fractional_difference_and_its_order_recovered():
    """``(1 - B)^d``'s coefficients are the binomial series
    ``(-1)^k C(d, k)`` (scipy); an ARFIMA(0, 0.4, 0) series (white noise
    through ``(1 - B)^-0.4``, the same closed form at ``-d``) of 10000
    samples gets ``d`` 0.4 back from :func:`noise_fit`'s grid (the
    estimate's sd is ``sqrt(6 / (pi^2 N)) = 0.0078``; the grid's step 0.05
    is the tolerance) and its innovation variance within level 0.001."""
    from scipy.special import binom
    from bayescal.coil.timedomain import fractional_difference, noise_fit
    k = np.arange(30)
    np.testing.assert_allclose(fractional_difference(0.37, 30), (-1.0) ** k * binom(0.37, k),
                               rtol=1e-12, atol=1e-15)
    n = 10000
    e = np.random.default_rng(4).standard_normal(2 * n)
    x = np.convolve(e, (-1.0) ** np.arange(2 * n) * binom(-0.4, np.arange(2 * n)))[n:2 * n]
    a, s2, d = noise_fit(x)
    assert d == pytest.approx(0.4, abs=0.051) and a.size <= 2, (d, a)
    assert s2 == pytest.approx(1.0, rel=float(norm.isf(LEVEL / 2)) * np.sqrt(2.0 / n))


def test_step_noise_model_follows_one_over_f_self_noise():
    """Self-noise with PSD 1/f in acceleration (the SBC's coloured runs):
    the noise model's innovations at the *truth* have their nominal power
    (1) at 1-10 mHz and 10-50 mHz, around the pendulum's corner where a
    step's period and damping are fixed, averaged over eight 20-minute runs
    (72 and 352 DFT bins: the means' sd 0.12 and 0.053; measured 1.17 and
    1.07). An AR alone (``d`` held at 0), fitted where most samples'
    variance is, does not follow 1/f down to the corner: 2.4 and 0.67."""
    low, mid = _band_means(range(61, 69), 1.0, ((1e-3, 1e-2), (1e-2, 5e-2)))
    assert 0.6 < low < 1.5 and 0.85 < mid < 1.2, (low, mid)


def test_a_record_long_whitening_filter_is_a_linear_convolution():
    """The step kind whitens with a filter as long as the record (the
    fractional difference): applied as a weight on the Predictor's FFT grid
    it must equal the same filter run from rest over the model in time (a
    step still on at the record's end, where a circular product wraps the
    record's own samples into its start)."""
    from bayescal.coil.timedomain import Predictor, fir, fractional_difference
    from scipy.fft import rfft

    fs, n = 10.0, 3000
    u = np.zeros(n)
    u[600:] = 1.0                                      # on until the end
    fc = 0.05

    def transfer(f):
        return 1.0 / (1.0 + 1j * np.asarray(f) / fc)  # causal one-pole low-pass

    b = fractional_difference(0.4, n)
    pred = Predictor(u, fs, transfer, pad=2000, span=n)
    linear = fir(b, pred(1.0)[0])
    weighted = pred(1.0, weight=rfft(b, n=pred.nfft))[0]
    # 2e-2 of the model with a buffer of n + taper + pad (the record wrapped in);
    # what is left is the buffer's own ringing tail (a step through an ideal filter)
    assert np.max(np.abs(weighted - linear)) < 1e-4 * np.max(np.abs(linear))


def test_least_squares_time_restores_the_d_grid_when_it_fails():
    """:func:`least_squares_time` narrows the model's ``d_grid`` to ``(0,)``
    for its first stage; a failure inside that stage leaves the model's
    grid as it was."""
    from bayescal.coil.timedomain import D_GRID, least_squares_time
    sim = simulate_step_cal(truth=TRUE_LP, seed=33, noise_ratio=0.01, **SHORT)
    model, _, theta, _ = least_squares_step(_run(sim), COIL)
    model.d_grid = D_GRID

    class Stop(Exception):
        pass

    def fail(theta):
        raise Stop

    model.estimate_noise = fail
    with pytest.raises(Stop):
        least_squares_time(model, theta)
    assert model.d_grid is D_GRID


def test_noise_fit_whitens_from_the_first_sample_as_the_likelihood():
    """:func:`noise_fit` with ``skip``: the fractional difference runs from
    the series' first sample and is cut at ``skip``, as
    :meth:`TimeModel.set_noise` whitens. A series of 2000 samples whose
    fractional difference of order 0.9 from its first sample is exactly
    ``e``, +-1 alternating after ``skip`` = 1000 (mean 0) and before it
    (the conditioned samples) ones shifted so that the series has mean 0
    after ``skip`` (``noise_fit`` takes that mean out): with ``d`` held at
    0.9 and no autoregression the innovation variance is the mean square of
    ``e`` after ``skip``, 1 (to round-off); restarted from rest at ``skip``
    (the long-memory filter's past dropped) it comes out 0.99955."""
    from bayescal.coil.timedomain import fir, fractional_difference, noise_fit
    n, skip, d = 2000, 1000, 0.9
    after = np.r_[np.zeros(skip), (-1.0) ** np.arange(n - skip)]
    before = np.r_[np.ones(skip), np.zeros(n - skip)]
    integrate = fractional_difference(-d, n)
    c0, c1 = (fir(integrate, v)[skip:].mean() for v in (after, before))
    e = after - (c0 / c1) * before
    x = fir(integrate, e)
    assert abs(x[skip:].mean()) < 1e-9
    a, s2, d_fit = noise_fit(x, max_order=0, d_grid=(d,), skip=skip)
    assert a.size == 0 and d_fit == d
    assert s2 == pytest.approx(1.0, abs=1e-9)
