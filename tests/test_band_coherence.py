"""The band choice's lean coherence (:mod:`bayescal.core.spectra.coherence`) gives the
coherence of the full cross-spectra to rounding, and the band the stated
rule picks from the full cross-spectra (the widest run, in log frequency,
where every SUT channel's multiple coherence, running median over a tenth
of a decade, reaches 0.9), written out here; and the fit in that band finds
the simulation's true angles: on the demo's simulated pair (whose coherence
is 0.995 at every frequency, so the band is the whole range the record
allows) and, when ``../shared/data`` holds it, ObsPy's huddle pair."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from bayescal.core.spectra.coherence import welch_multiple_coherence
from bayescal.core.spectra.welch import cross_spectra
from bayescal.io.align import align
from bayescal.io.band import choose_band

ROOT = Path(__file__).resolve().parents[1]
HUDDLE = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
#: examples/demo.py's truth, as benchmarks/bench_process.py simulates it
DEMO = dict(duration=7200, fs=20, seed=2026, coherence=0.995, sut_azimuth=(3.0, 93.4, 25.0),
            sut_dip=(0.0, 0.3, -89.6), nominal_response=(30.0, 0.707, 750.0),
            sut_response=((28.5, 0.69, 761.0), (31.0, 0.72, 744.0), (30.0, 0.70, 752.0)))


def _rule_band(freqs, coherence, threshold=0.9, decades=0.1, min_ratio=1.5):
    """The stated rule on (n_u, F) multiple coherence: running median over
    ``decades`` of log frequency, then the widest run (in log frequency)
    where every channel that reaches ``threshold`` anywhere is above it."""
    logf = np.log10(freqs)
    smooth = np.array([[np.median(c[np.abs(logf - lf) <= decades / 2 + 1e-12]) for lf in logf]
                       for c in np.clip(coherence, 0, 1)])
    ok = np.all(smooth[smooth.max(axis=1) >= threshold] >= threshold, axis=0)
    best, start = None, None
    for k, good in enumerate(np.r_[ok, False]):
        if good and start is None:
            start = k
        elif not good and start is not None:
            if best is None or logf[k - 1] - logf[start] > best[1] - best[0]:
                best = (logf[start], logf[k - 1], start, k - 1)
            start = None
    assert best is not None and freqs[best[3]] / freqs[best[2]] >= min_ratio
    return float(freqs[best[2]]), float(freqs[best[3]])


def _check_coherence(s, r, fs):
    """The lean coherence against the full cross-spectra's, and the chosen
    band against the rule applied to the full cross-spectra's coherence."""
    n = s.data.shape[1]
    nperseg = int(2 ** np.floor(np.log2(n / 8)))
    lo, hi = 10.0 * fs / nperseg, 0.8 * fs / 2
    full = cross_spectra(s.data, r.data, fs, None, None, (lo, hi), nperseg=nperseg)
    freqs, coh = welch_multiple_coherence(s.data, r.data, fs, (lo, hi), nperseg)
    np.testing.assert_array_equal(freqs, full.freqs)
    np.testing.assert_allclose(coh, full.multiple_coherence(), rtol=0, atol=1e-10)
    choice = choose_band(s, r, fs)
    assert choice.band == _rule_band(full.freqs, full.multiple_coherence())
    return choice, full.freqs


@pytest.fixture(scope="module")
def demo():
    from bayescal.simulate.pair import simulate_pair
    return simulate_pair(**DEMO)


def test_demo_band_and_fit_find_the_truth(demo):
    from tests.fitting import fit_sim

    s, r, fs, _ = align(demo.sut, demo.sut_inventory, demo.ref, demo.ref_inventory)
    choice, freqs = _check_coherence(s, r, fs)
    # coherence 0.995 at every frequency: the whole range the record allows
    assert choice.band == (freqs[0], freqs[-1])
    post = fit_sim(demo, progress=False)
    assert tuple(post.meta.band_hz) == choice.band
    # every angle within 3.5 posterior sd (half the 68 % interval) of the
    # simulation's truth: a per-angle level of 5e-4, 0.003 over the five
    summary = post.summary()["channels"]
    for (cid, e), az, dip in zip(summary.items(), DEMO["sut_azimuth"], DEMO["sut_dip"]):
        checks = [("dip_deg", dip)] + ([("azimuth_deg", az)] if abs(dip) < 80 else [])
        for key, truth in checks:
            lo, hi = e[key]["ci68"]
            assert abs(e[key]["median"] - truth) < 3.5 * (hi - lo) / 2, (cid, key, e[key])


@pytest.mark.skipif(not HUDDLE.is_dir(), reason=f"real data folder {HUDDLE} is absent")
def test_huddle_band_follows_the_rule(tmp_path):
    from bayescal import io
    from bayescal.io.inventory import load_inventory

    sys.path.insert(0, str(ROOT / "examples"))
    from real_huddle import write_inputs

    ref_xml, sut_xml = write_inputs(HUDDLE, str(tmp_path))
    ref = io.read_waveforms(HUDDLE / "ref_STS2")
    sut = io.read_waveforms(HUDDLE / "ref_unknown")
    s, r, fs, _ = align(sut, load_inventory(sut_xml, sut), ref, load_inventory(ref_xml, ref))
    _check_coherence(s, r, fs)


def test_gaps_drop_segments_and_too_few_refuse():
    from bayescal.errors import SpectraError

    rng = np.random.default_rng(1)
    g = rng.standard_normal(4096)
    sut = np.vstack([g + 0.1 * rng.standard_normal(4096)])
    ref = np.vstack([g])
    freqs, coh = welch_multiple_coherence(sut, ref, 1.0, (0.05, 0.4), 256)
    assert np.all(coh > 0.9) and np.all(coh <= 1 + 1e-12)
    sut[0, 300:3800] = np.nan
    with pytest.raises(SpectraError, match="gap-free segments"):
        welch_multiple_coherence(sut, ref, 1.0, (0.05, 0.4), 256)
