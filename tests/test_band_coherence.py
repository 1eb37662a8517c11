"""The band choice's lean coherence (:mod:`bayescal.core.coherence`) gives the
coherence of the full cross-spectra to rounding and the same chosen band as
the full cross-spectra did (the bands recorded where the band choice
computed the fit's full :class:`CrossSpectra`), and the fit in that band
finds the simulation's true angles: on the demo's simulated pair and, when
``../shared/data`` holds it, ObsPy's huddle pair."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from bayescal.core.coherence import welch_multiple_coherence
from bayescal.core.spectra import cross_spectra
from bayescal.io.align import align
from bayescal.io.band import choose_band

ROOT = Path(__file__).resolve().parents[1]
HUDDLE = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
#: examples/demo.py's truth, as benchmarks/bench_process.py simulates it
DEMO = dict(duration=7200, fs=20, seed=2026, coherence=0.995, sut_azimuth=(3.0, 93.4, 25.0),
            sut_dip=(0.0, 0.3, -89.6), nominal_response=(30.0, 0.707, 750.0),
            sut_response=((28.5, 0.69, 761.0), (31.0, 0.72, 744.0), (30.0, 0.70, 752.0)))
#: the band the full cross-spectra chose
DEMO_BAND = (0.01220703125, 7.999267578125)
HUDDLE_BAND = (0.03662109375, 47.723388671875)


def _check_coherence(s, r, fs, band):
    """The lean coherence against the full cross-spectra's, over ``band``."""
    n = s.data.shape[1]
    nperseg = int(2 ** np.floor(np.log2(n / 8)))
    lo = 10.0 * fs / nperseg
    full = cross_spectra(s.data, r.data, fs, None, None, (lo, 0.8 * fs / 2), nperseg=nperseg)
    freqs, coh = welch_multiple_coherence(s.data, r.data, fs, (lo, 0.8 * fs / 2), nperseg)
    np.testing.assert_array_equal(freqs, full.freqs)
    np.testing.assert_allclose(coh, full.multiple_coherence(), rtol=0, atol=1e-10)
    choice = choose_band(s, r, fs)
    assert choice.band == band
    return choice


@pytest.fixture(scope="module")
def demo():
    from bayescal.simulate.pair import simulate_pair
    return simulate_pair(**DEMO)


def test_demo_band_and_fit_find_the_truth(demo):
    from bayescal import calibrate

    s, r, fs, _ = align(demo.sut, demo.sut_inventory, demo.ref, demo.ref_inventory, "SUT",
                        "reference", None, None)
    _check_coherence(s, r, fs, DEMO_BAND)
    post = calibrate(sut=demo.sut, sut_xml=demo.sut_inventory, ref=demo.ref, ref_xml=demo.ref_inventory,
                     progress=False)
    assert tuple(post.meta["band_hz"]) == DEMO_BAND
    # every angle within 3.5 posterior sd (half the 68 % interval) of the
    # simulation's truth: a per-angle level of 5e-4, 0.003 over the five
    summary = post.summary()["channels"]
    for (cid, e), az, dip in zip(summary.items(), DEMO["sut_azimuth"], DEMO["sut_dip"]):
        checks = [("dip_deg", dip)] + ([("azimuth_deg", az)] if abs(dip) < 80 else [])
        for key, truth in checks:
            lo, hi = e[key]["ci68"]
            assert abs(e[key]["median"] - truth) < 3.5 * (hi - lo) / 2, (cid, key, e[key])


@pytest.mark.skipif(not HUDDLE.is_dir(), reason="needs ../shared/data/real/obspy_relcal")
def test_huddle_band_unchanged(tmp_path):
    from bayescal import io
    from bayescal.io.pipeline import load_inventory

    sys.path.insert(0, str(ROOT / "examples"))
    from real_huddle import write_inputs

    ref_xml, sut_xml = write_inputs(HUDDLE, str(tmp_path))
    ref = io.read_waveforms(HUDDLE / "ref_STS2")
    sut = io.read_waveforms(HUDDLE / "ref_unknown")
    s, r, fs, _ = align(sut, load_inventory(sut_xml, sut), ref, load_inventory(ref_xml, ref),
                        "SUT", "reference", None, None)
    _check_coherence(s, r, fs, HUDDLE_BAND)


def test_gaps_drop_segments_and_too_few_refuse():
    from bayescal.core.spectra import SpectraError

    rng = np.random.default_rng(1)
    g = rng.standard_normal(4096)
    sut = np.vstack([g + 0.1 * rng.standard_normal(4096)])
    ref = np.vstack([g])
    freqs, coh = welch_multiple_coherence(sut, ref, 1.0, (0.05, 0.4), 256)
    assert np.all(coh > 0.9) and np.all(coh <= 1 + 1e-12)
    sut[0, 300:3800] = np.nan
    with pytest.raises(SpectraError, match="gap-free segments"):
        welch_multiple_coherence(sut, ref, 1.0, (0.05, 0.4), 256)
