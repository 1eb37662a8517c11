"""Seeded draws that the validation studies (``validation/studies/``) and the
test suite share, so that a test and the study it stands for simulate the
same pairs:

* the errors-in-variables regimes: :data:`NOMINAL`, :func:`coherences`,
  :func:`draw_truth` (``eiv_coverage.py`` and the studies built on it);
* the diagnosis harness's concealed effects: :data:`KINDS`, :data:`REGIMES`,
  :func:`regime_kw`, :func:`draw_effect`, :func:`concealed_pair`
  (``diagnose_harness.py``);
* a tilted pair's cross-spectra as a fit prepares them:
  :func:`tilt_pair_spectra` (``tilt_power.py``);
* each channel's true self-noise per band as the pair-noise estimator
  defines it: :func:`band_noise_truth` (``pair_noise_study.py``).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .pair import self_noise_psd, simulate_pair

#: Nominal (period s, damping, gain) of every channel in the
#: errors-in-variables regimes.
NOMINAL = (30.0, 0.707, 750.0)


def coherences(pair_coherence, ratio):
    """(SUT, reference) squared coherence with the ground for a pair
    coherence ``c_u c_r`` and a reference/SUT noise-power ratio ``ratio``
    (noise-to-signal ``x`` and ``ratio * x``); ratio 0: reference noise-free
    (coherence 0.99999)."""
    from scipy.optimize import brentq

    if ratio == 0:
        return pair_coherence / 0.99999, 0.99999
    x = brentq(lambda x: (1 + x) * (1 + ratio * x) - 1 / pair_coherence, 0, 10)
    return 1 / (1 + x), 1 / (1 + ratio * x)


def draw_truth(seed, fit):
    """Random orientation and response of one errors-in-variables pair
    (seeded): azimuths, dips and ``(period, damping, gain)`` per channel;
    gains within 3 % of :data:`NOMINAL`, period and damping within 5 % when
    ``fit == "all"``."""
    rng = np.random.default_rng(20_000 + seed)
    az = rng.uniform(0, 360)
    azs = (az, az + 90 + rng.normal(0, 1), rng.uniform(0, 360))
    dips = (rng.normal(0, 1), rng.normal(0, 1), -90 + abs(rng.normal(0, 1)))
    gains = NOMINAL[2] * (1 + rng.uniform(-0.03, 0.03, 3))
    if fit == "all":
        per = NOMINAL[0] * (1 + rng.uniform(-0.05, 0.05, 3))
        damp = NOMINAL[1] * (1 + rng.uniform(-0.05, 0.05, 3))
    else:
        per, damp = np.full(3, NOMINAL[0]), np.full(3, NOMINAL[1])
    return azs, dips, tuple(zip(per, damp, gains))


#: The effects the diagnosis harness hides, one per run.
KINDS = ["timing_offset", "clock_drift", "extra_pole", "gain_error", "polarity_reversal",
         "channel_swap", "tilt_noise"]
#: Noise regimes of the runs: (reference coherence, self-noise white in counts).
#: "default": a reference 100x quieter than the SUT's quietest draw (the base
#: model's assumption); "equal": the reference as noisy as the SUT (a huddle of
#: two sensors of one class), noise shaped like the ground; "equal-counts": the
#: same, white in counts (rising in velocity below each sensor's corner, as
#: real self-noise does); "ref10x": the reference 10x quieter than the SUT.
REGIMES = ("default", "equal", "equal-counts", "ref10x")


def regime_kw(regime, coherence):
    """:func:`simulate_pair` keyword arguments of a noise regime at SUT
    ``coherence``."""
    if regime == "default":
        return {}
    if regime == "ref10x":
        return {"ref_coherence": 1.0 / (1.0 + 0.1 * (1.0 - coherence) / coherence)}
    if regime in ("equal", "equal-counts"):
        return {"ref_coherence": coherence, "noise_in_counts": regime == "equal-counts"}
    raise ValueError(f"unknown regime {regime!r}; one of {REGIMES}")


def draw_effect(rng, p_clean):
    """(kind, :func:`simulate_pair` keyword arguments, truth size) for one
    run: no effect (``"none"``) with probability ``p_clean``, otherwise one
    of :data:`KINDS` with a random size."""
    if rng.uniform() < p_clean:
        return "none", {}, None
    kind = KINDS[rng.integers(len(KINDS))]
    sign = rng.choice([-1, 1])
    if kind == "timing_offset":
        s = sign * rng.uniform(0.01, 0.5)
        return kind, {"timing_offset_s": s}, {"seconds": s}
    if kind == "clock_drift":
        p = sign * rng.uniform(5, 100)
        return kind, {"clock_drift_ppm": p}, {"ppm": p}
    if kind == "extra_pole":
        which = str(rng.choice(["sut", "ref"]))
        fc = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        return kind, {"extra_pole": (which, fc)}, {"corner_hz": fc, "which": which}
    if kind == "gain_error":
        ch, frac = int(rng.integers(3)), sign * rng.uniform(0.01, 0.1)
        resp = [(30.0, 0.707, 750.0)] * 3
        resp[ch] = (30.0, 0.707, 750.0 * (1 + frac))
        return kind, {"sut_response": tuple(resp)}, {"fraction": frac, "row": ch}
    if kind == "polarity_reversal":
        ch = int(rng.integers(3))
        return kind, {"polarity_reversal": ch}, {"row": ch}
    if kind == "channel_swap":
        pair = tuple(sorted(int(x) for x in rng.choice(3, 2, replace=False)))
        return kind, {"channel_swap": pair}, {"rows": list(pair)}
    level = float(np.exp(rng.uniform(np.log(5), np.log(100))))
    return kind, {"tilt_noise": level}, {"level": level}


def concealed_pair(seed, p_clean, regime="default", gain_off=0.0, ground=None, duration=3600.0,
                   fs=10.0, counts=None):
    """One seeded run of the diagnosis harness: a pair (3600 s at 10 Hz,
    coherence drawn in 0.9-0.995, random azimuth, metadata azimuths within 3
    degrees of the truth) with an effect drawn by :func:`draw_effect` hidden
    in it, in noise regime ``regime``; with ``gain_off`` each SUT gain is
    off its metadata by up to that fraction (its own generator, so the other
    draws match ``gain_off = 0``); ``ground``: the family of ground spectra
    (:func:`simulate_pair`'s; None the default plane waves), ``duration`` (s)
    and ``fs`` (Hz) the record's; ``counts`` (not None) sets whether both
    sensors' self-noise is white in counts, whatever the regime. Returns a namespace with ``sim`` (the
    :func:`simulate_pair` result), ``kind``, ``kw`` (the effect's keyword
    arguments), ``truth`` and ``coherence``."""
    rng = np.random.default_rng(seed)
    kind, kw, truth = draw_effect(rng, p_clean)
    a = rng.uniform(0, 360)
    coherence = float(rng.uniform(0.9, 0.995))
    az, dip = (a, a + 90, 0.0), (0.0, 0.0, -90.0)
    nom_az = tuple(x + rng.uniform(-3, 3) for x in az[:2]) + (0.0,)
    extra = regime_kw(regime, coherence)
    if counts is not None:
        extra = dict(extra, noise_in_counts=bool(counts))
    if gain_off and "sut_response" not in kw:
        off = np.random.default_rng([seed, 7]).uniform(-gain_off, gain_off, 3)
        kw = dict(kw, sut_response=tuple((30.0, 0.707, 750.0 * (1 + o)) for o in off))
    sim = simulate_pair(duration=duration, fs=fs, seed=seed, coherence=coherence, sut_azimuth=az,
                        sut_dip=dip, nominal_azimuth=nom_az, nominal_dip=dip, ground=ground,
                        **extra, **kw)
    return SimpleNamespace(sim=sim, kind=kind, kw=kw, truth=truth, coherence=coherence)


def tilt_pair_spectra(seed, coherence, azimuth, level, band=(0.02, 3.0), **effects):
    """Cross-spectra of one simulated pair (3600 s at 10 Hz, SUT turned by
    ``azimuth``, tilt noise ``level`` on SUT channels 0 and 1), as a fit
    prepares them (:func:`bayescal.pair.prepare`, every segment kept);
    ``effects`` go to :func:`simulate_pair`."""
    from ..pair import prepare

    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence,
                        sut_azimuth=(azimuth, azimuth + 90, 0.0), tilt_noise=level, **effects)
    return prepare(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                   sut_xml=sim.sut_inventory, band=band, transients="keep").spectra


def band_noise_truth(spectra, kw):
    """True self-noise of every channel (SUT rows then reference rows) per
    band of ``spectra``, as the pair-noise estimator defines it: band-mean
    velocity PSD over band-mean 1/omega^2; ``kw`` are the
    :func:`simulate_pair` arguments of the pair."""
    tu, tr = self_noise_psd(spectra.freqs, **kw)
    tru = np.concatenate([tu, tr])
    iw = 1.0 / (2 * np.pi * spectra.freqs) ** 2
    return np.stack([tru[:, spectra.band_of == b].mean(1) / iw[spectra.band_of == b].mean()
                     for b in range(spectra.n_bands)], axis=1)
