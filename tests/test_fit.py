"""End-to-end inference on simulated pairs with known truth.

Single-seed tests assert the accuracy targets (0.1 degree, 0.3 %) and that each truth
lies within 4 posterior sd of the median (a 95 % check on many parameters
would fail by chance); calibration of the intervals themselves is a
statistical claim, tested over many seeds in test_coverage.py."""
import numpy as np
import pytest
from scipy.stats import norm

import bayescal
from bayescal.core.orientation.geometry import unwrap_azimuths
from bayescal.io.result import load_posterior, save_posterior
from bayescal.simulate.pair import simulate_pair
from tests.fitting import fit_sim
from tests.tolerance import LEVEL, Z_001, median_mc_error


@pytest.fixture(scope="module")
def high_coherence_fit():
    # gains off nominal; period and damping nominal (only gains are fitted here)
    resp = ((30.0, 0.707, 757.0), (30.0, 0.707, 745.0), (30.0, 0.707, 752.0))
    sim = simulate_pair(duration=7200, fs=10, seed=11, coherence=0.995, sut_azimuth=(3.0, 93.2, 0.0),
                        sut_dip=(0.2, -0.3, -89.6), sut_response=resp)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.03, 1.0), fit_response="gain", seed=3, progress=False)
    return sim, post


def test_recovery_high_coherence(high_coherence_fit):
    sim, post = high_coherence_fit
    summary = post.summary()["channels"]
    for cid, truth in sim.truth["channels"].items():
        got = summary[cid]
        if truth["dip_deg"] > -80:
            err = unwrap_azimuths(np.r_[got["azimuth_deg"]["median"], truth["azimuth_deg"]])
            assert abs(err[0] - err[1]) < 0.1                       # target: < 0.1 degree
            assert abs(err[0] - err[1]) < 4 * got["azimuth_deg"]["sd"]
            assert abs(got["dip_deg"]["median"] - truth["dip_deg"]) < 4 * got["dip_deg"]["sd"]
        else:
            t = got["tilt_deg"]
            assert abs(t["median"] - (90 + truth["dip_deg"])) < 4 * t["sd"]
            assert got["azimuth_deg"]["undefined"] and "ci95" not in got["azimuth_deg"]
        g = got["response"]["gain"]
        assert abs(g["median"] / truth["gain"] - 1) < 0.003         # target: within 0.3 %
        assert abs(g["median"] - truth["gain"]) < 4 * g["sd"]


def test_convergence_rule_met(high_coherence_fit):
    _, post = high_coherence_fit
    c = post.summary()["convergence"]
    assert c["converged"] and c["ess_min"] >= 1000 and c["rhat_max"] < 1.01
    assert c["n_steps"] - post.convergence.burn >= 50 * c["tau_max"]


def test_turned_swapped_and_reversed_sensor_found_without_nominal_help():
    """Metadata say N, E, up; truth: turned by 180 degrees, horizontals
    swapped, vertical reversed (pointing down, dip +90). The azimuths lie
    within 3.29 posterior sd of 273 and 183 (two-sided level 0.001 each);
    the vertical points down, and its lean's north and east components lie
    within 3.29 sd of the truth's 0 (the lean's size cannot: it is never
    negative)."""
    sim = simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99, sut_azimuth=(273.0, 183.0, 0.0),
                        sut_dip=(0.0, 0.0, 90.0))
    post = fit_sim(sim, band=(0.03, 1.0), seed=1, progress=False)
    ch = post.summary()["channels"]
    for c, truth in zip("12", (273.0, 183.0)):
        az = ch[f"XX.SIM.10.BH{c}"]["azimuth_deg"]
        assert abs(az["median"] - truth) < Z_001 * az["sd"], (c, az)
    z = ch["XX.SIM.10.BHZ"]
    assert z["dip_deg"]["median"] > 0          # down, where the metadata say up
    for key in ("tilt_north_deg", "tilt_east_deg"):
        assert abs(z[key]["median"]) < Z_001 * z[key]["sd"], (key, z[key])


def test_non_orthogonal_channels_and_reproducible():
    sim = simulate_pair(duration=3600, fs=10, seed=7, coherence=0.99, sut_azimuth=(10.0, 97.0, 0.0),
                        sut_dip=(0.0, 1.5, -90.0))
    kw = dict(band=(0.03, 1.0), seed=4, progress=False)
    a = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, **kw)
    b = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, **kw)
    assert np.array_equal(a.samples, b.samples)
    summ = a.summary()
    ch, ess = summ["channels"], summ["convergence"]["ess_min"]
    # 87 degrees between the horizontals, the second dipping 1.5 degrees: the
    # two azimuths are fitted from independent noise (one channel each), so
    # their difference has sd hypot(sd1, sd2); Z_001 of it (medians' Monte
    # Carlo errors added), one check at the suite's level 0.001
    a1, a2 = ch["XX.SIM.10.BH1"]["azimuth_deg"], ch["XX.SIM.10.BH2"]["azimuth_deg"]
    tol = Z_001 * np.sqrt(a1["sd"] ** 2 + a2["sd"] ** 2 + median_mc_error(a1, ess) ** 2
                          + median_mc_error(a2, ess) ** 2)
    assert abs(a2["median"] - a1["median"] - 87.0) < tol, (a1, a2, tol)
    lo, hi = ch["XX.SIM.10.BH2"]["dip_deg"]["ci95"]
    assert lo <= 1.5 <= hi


def test_joint_response_recovered(tmp_path):
    resp = ((27.0, 0.66, 770.0),) * 3
    sim = simulate_pair(duration=3600, fs=10, seed=2, coherence=0.995, sut_response=resp,
                        sut_azimuth=(5.0, 95.0, 0.0))
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.01, 1.0), fit_response="all", seed=2, progress=False)
    save_posterior(post, tmp_path)
    summ = load_posterior(tmp_path).summary()
    again, ess = summ["channels"], summ["convergence"]["ess_min"]
    # 9 checks (3 channels x 3 parameters) at the suite's level 0.001 together:
    # Bonferroni, |z| < 3.87 each, with the median's Monte Carlo error added
    z9 = float(norm.isf(LEVEL / (2 * 9)))
    for cid in sim.truth["channels"]:
        r = again[cid]["response"]
        for name, truth in zip(("period_s", "damping", "gain"), resp[0]):
            tol = z9 * np.hypot(r[name]["sd"], median_mc_error(r[name], ess))
            assert abs(r[name]["median"] - truth) < tol, (cid, name, r[name], truth)
        assert r["period_s"]["median"] == pytest.approx(27.0, rel=0.02)
