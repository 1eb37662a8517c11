"""bayescal diagnose on simulated pairs with a concealed effect: the effect is
found, named, and its size recovered within its interval; a clean pair
raises no alarm; the command works end to end on written files."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.special import gammainccinv
from scipy.stats import chi2

import bayescal
from bayescal.criticism.diagnose import diagnose
from bayescal.simulate.pair import simulate_pair
from tests.closed_forms import HANN_DOF_LOSS, drift_rate_crb_ppm, sd_mc_factor
from tests.tolerance import LEVEL, Z_001

AZ = (5.0, 95.0, 0.0)


def _diagnose(band=(0.05, 3.0), seed=1, coherence=0.99, fit_response="gain", **effect):
    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence, sut_azimuth=AZ,
                        nominal_azimuth=(3.0, 93.0, 0.0), **effect)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=band,
                              progress=False, min_ess=200, n_tau=20, fit_response=fit_response,
                              ref_noise="quiet", diagnose=False)
    return diagnose(post.state, mcmc=False)


def _only(d, name):
    assert d.names == [name], d.sentences()
    return d.effects[0]


def _inside(entry, key, truth):
    p = entry["parameters"][key]
    assert p["ci95"][0] <= truth <= p["ci95"][1], (key, truth, p)


def test_clean_pair_raises_no_alarm():
    d = _diagnose()
    assert d.effects == []
    assert d.before["mismatch"] == []
    assert "no mismatch" in d.sentences()[0]


def test_timing_offset_found_and_sized():
    d = _diagnose(timing_offset_s=0.12)
    e = _only(d, "timing_offset")
    _inside(e, "seconds", 0.12)
    # the BIC gain of one added parameter is 2 dlogL - log n: the offset is
    # significant at level 0.001 (likelihood ratio above chi2_1's 10.83)
    # at least when the gain exceeds 10.83
    assert e["score_gain"] > chi2.isf(LEVEL, 1)
    # each misfit cell is Gamma(n_r, 1) / n_r where the model fits (n_r = 3
    # reference channels): the base model has a cell beyond the Bonferroni
    # bound of level 0.001 over the cells (5.06 for 30 cells), the improved none
    bound = gammainccinv(3, LEVEL / d.before["misfit"].size) / 3
    assert d.before["misfit"].max() > bound > d.after["misfit"].max(), bound
    assert "0.12 s late" in d.sentences()[0]


@pytest.mark.parametrize("which", ["sut", "ref"])
def test_extra_pole_on_the_right_sensor(which):
    d = _diagnose(extra_pole=(which, 0.8))
    e = _only(d, "extra_pole")
    assert e["parameters"]["which"] == which
    _inside(e, "corner_hz", 0.8)


def test_gain_error_on_one_channel():
    """With the gains held (--fit-response none) a gain error is an effect to
    name; by default the gain is a fitted parameter instead."""
    resp = ((30.0, 0.707, 750.0), (30.0, 0.707, 750.0 * 0.95), (30.0, 0.707, 750.0))
    d = _diagnose(sut_response=resp, fit_response="none")
    e = _only(d, "gain_error")
    assert e["channels"] == ["XX.SIM.10.BH2"]
    _inside(e, "fraction", -0.05)


def test_polarity_reversal_and_swap_named_and_scored():
    d = _diagnose(polarity_reversal=2)
    e = _only(d, "polarity_reversal")
    assert e["channels"] == ["XX.SIM.10.BHZ"]
    assert e["score_gain"] > 1000
    d = _diagnose(channel_swap=(0, 1))
    e = _only(d, "channel_swap")
    assert sorted(e["channels"]) == ["XX.SIM.10.BH1", "XX.SIM.10.BH2"]
    assert e["score_gain"] > 1000


@pytest.mark.parametrize("ppm", [60.0, -8.0])
def test_clock_drift_rate_and_sign_from_the_posterior(ppm):
    d = _diagnose(clock_drift_ppm=ppm)
    e = _only(d, "clock_drift")
    _inside(e, "ppm", ppm)
    # the rate's sd between its Cramer-Rao bound and the Hann-window bound
    # (tests/closed_forms.py), widened by the sd's Monte Carlo error (the
    # diagnosis's Laplace draws: ESS = their number)
    sd = e["parameters"]["ppm"]["sd"]
    crb = drift_rate_crb_ppm(d.base.spectra, 0.99, 0.9999, 3)
    mc = sd_mc_factor(len(d.final.samples), Z_001)
    assert crb * (1 - mc) <= sd <= crb * np.sqrt(HANN_DOF_LOSS) * (1 + mc), (sd, crb)
    t_mid = d.base.spectra.segment_times().mean()
    _inside(e, "seconds_mid", ppm * 1e-6 * t_mid)


@pytest.mark.parametrize("level, coherence", [(30.0, 0.99), (10.0, 0.93)])
def test_tilt_noise_modelled_on_horizontals(level, coherence):
    """Strong tilt, and weak tilt at a coherence the earlier coherence-ratio
    rule missed: named on both horizontals, the simulated f^-2 recovered."""
    d = _diagnose(band=(0.02, 3.0), tilt_noise=level, coherence=coherence)
    e = _only(d, "tilt_noise")
    assert e["channels"] == ["XX.SIM.10.BH1", "XX.SIM.10.BH2"]
    assert e["score_gain"] > 10
    _inside(e, "alpha", 2.0)
    assert d.final is d.base       # noise, not a response error: the estimates do not move


def test_cli_end_to_end(tmp_path):
    from bayescal.cli import main

    sim = simulate_pair(duration=3600, fs=10, seed=2, coherence=0.99, sut_azimuth=AZ,
                        timing_offset_s=-0.2)
    p = sim.write(tmp_path / "in")
    out = tmp_path / "out"
    code = main(["diagnose", "--ref", p["ref.mseed"], "--ref-xml", p["ref.xml"], "--sut",
                 p["sut.mseed"], "--sut-xml", p["sut.xml"], "--out", str(out), "--band", "0.05",
                 "3", "--quiet"])
    assert code == 0
    doc = json.loads((out / "diagnosis.json").read_text())
    assert doc["schema"] == "bayescal.diagnose/1"
    assert [e["name"] for e in doc["effects"]] == ["timing_offset"]
    s = doc["effects"][0]["parameters"]["seconds"]
    assert s["ci95"][0] <= -0.2 <= s["ci95"][1]
    assert doc["base"]["schema"] == doc["final"]["schema"] == "bayescal.fit/1"
    assert doc["mismatch"] and doc["mismatch"][0]["p_value"] < 1e-6
    assert (out / "diagnosis.pdf").stat().st_size > 0 and (out / "result.json").exists()
    assert np.isfinite(doc["final"]["convergence"]["ess_min"])


def test_cli_clean_pair_writes_the_base_fit(tmp_path):
    """When nothing is modelled, the result.json that ``bayescal diagnose``
    writes is the base fit as ``bayescal fit`` reports it (diagnosis.json's
    ``base``), its self-noise and sensor order included."""
    from bayescal.cli import main

    p = simulate_pair(duration=1800, fs=10, seed=4, coherence=0.99).write(tmp_path / "in")
    out = tmp_path / "out"
    code = main(["diagnose", "--ref", p["ref.mseed"], "--ref-xml", p["ref.xml"], "--sut",
                 p["sut.mseed"], "--sut-xml", p["sut.xml"], "--out", str(out), "--band", "0.05",
                 "3", "--quiet", "--no-report"])
    assert code == 0
    doc = json.loads((out / "diagnosis.json").read_text())
    result = json.loads((out / "result.json").read_text())
    assert doc["effects"] == []
    assert "self_noise" in result and "sensor_order" in result
    assert result == doc["base"] == doc["final"]


@pytest.mark.parametrize("side", ["--sut", "--ref"])
def test_cli_bad_input_one_line_naming_the_file(sim_files, tmp_path, capsys, side):
    """An unreadable waveform file on either side (the other side's files
    good): exit code 2, exactly one line on stderr, ``bayescal: error:``
    followed by that file's path and what is wrong with it, no traceback,
    nothing written; a missing file likewise, the side named."""
    from bayescal.cli import main

    bad = tmp_path / "bad.mseed"
    bad.write_text("not a waveform")
    files = {"--ref": sim_files["ref.mseed"], "--sut": sim_files["sut.mseed"]}
    named = {"--ref": "reference", "--sut": "SUT"}[side]
    for path, what in ((bad, "not a waveform file ObsPy can read ("),
                       (tmp_path / "missing.mseed", f"{named} waveform file not found")):
        out = tmp_path / "out"
        args = dict(files, **{side: path})
        code = main(["diagnose", "--ref", str(args["--ref"]), "--ref-xml", str(sim_files["ref.xml"]),
                     "--sut", str(args["--sut"]), "--sut-xml", str(sim_files["sut.xml"]),
                     "--out", str(out), "--quiet"])
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert code == 2
        assert len(lines) == 1, lines
        assert lines[0].startswith(f"bayescal: error: {path}: {what}"), lines[0]
        assert "Traceback" not in captured.err and captured.out == ""
        assert not out.exists()
        assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.tmp")]


def test_misfit_sentence_says_rises_when_it_rose():
    """A misfit whose median rose (8.55e3 -> 1.46e4) is said to rise, not fall."""
    import numpy as np

    from bayescal.criticism.diagnosis import misfit_change

    edges = np.array([0.02, 0.1, 3.0])
    up = misfit_change(edges, np.array([8.55e3, 8.55e3]), np.array([1.46e4, 1.46e4]))
    assert "rises from median 8.55e+03" in up and "to median 1.46e+04" in up
    assert "falls" in misfit_change(edges, np.array([9.0, 9.0]), np.array([1.1, 1.1]))
