"""A multimodal posterior is reported as such (issue 13 item 4).

* the pieces, on numbers with a known answer: the central-difference
  curvature of a quadratic, two equal modes weigh one half each, the merge
  distance for one parameter, an interval marked only when a significant
  mode lies outside it;
* a genuinely bimodal pair: one plane wave, no diffuse field, a two-channel
  horizontal reference and the gains held. The ground moves along one
  horizontal direction ``d`` only, so a SUT horizontal at azimuth ``a`` and
  its mirror ``2 d - a`` record the same signal. Both modes are found at
  those values (``d`` measured here from the reference's recordings), the
  flag is raised in result.json, on the console's second line and on
  page 1 of the report, and the sampled interval is marked;
* a normal, demo-like pair (six waves and a diffuse field): every other
  start ends far below the first optimum, no flag and nothing marked;
* the real ASL COWI pair (skips without ../shared/data): no flag.
"""
from __future__ import annotations

import io
import json

import numpy as np
import pytest

from bayescal.core.fit import modes
from bayescal.core.posterior import modes as reported


def test_curvature_of_a_quadratic_and_equal_modes():
    a = np.array([[3.0, 0.5], [0.5, 2.0]])
    centre = np.array([0.3, -1.0])

    def log_prob(x):
        d = np.atleast_2d(x) - centre
        return -0.5 * np.einsum("ni,ij,nj->n", d, a, d)

    grad, hess = modes.curvature(log_prob, np.array([0.5, -1.0]), np.array([0.1, 0.1]))
    assert np.allclose(hess, a, atol=1e-9)
    assert np.allclose(grad, a @ np.array([0.2, 0.0]), atol=1e-9)
    # two optima of equal height and width: half the mass each; 4.6 below: 1 %
    assert np.allclose(modes.mass_fractions([-7.0, -7.0]), [0.5, 0.5])
    assert modes.mass_fractions([0.0, -np.log(99.0)])[1] == pytest.approx(0.01)
    # one parameter: the 99 % intervals (+-2.576 sd) touch at 5.15 sd
    assert modes.merge_threshold(1) == pytest.approx(2 * 2.5758, abs=1e-3)


def test_mark_only_when_a_significant_mode_lies_outside():
    report = {"detected": True, "mass_threshold": 0.01,
              "modes": [{"mass_fraction": 0.7, "channels": {"A": {"azimuth_deg": 359.0}}},
                        {"mass_fraction": 0.295, "channels": {"A": {"azimuth_deg": 40.0}}},
                        {"mass_fraction": 0.005, "channels": {"A": {"azimuth_deg": 90.0}}}]}
    entry = {"azimuth_deg": {"median": -1.0, "ci95": [-1.5, -0.5]}}
    assert reported.mark_channel(entry, "A", report) == ["azimuth_deg"]
    az = entry["azimuth_deg"]
    assert az["multimodal"] is True
    # the sampled mode's 359 is shown as -1 (contiguous with its interval);
    # the 0.5 % mode is below the threshold and not listed
    assert [m["value"] for m in az["modes"]] == [-1.0, 40.0]
    assert "70 %" in az["note"]
    inside = {"azimuth_deg": {"median": 10.0, "ci95": [-5.0, 45.0]}}
    assert reported.mark_channel(inside, "A", report) == []
    assert reported.mark_channel(entry, "A", {**report, "detected": False}) == []


def _mirror_direction(ref):
    """Azimuth (degrees, modulo 180) of the horizontal direction the ground
    moves along: the principal axis of the reference's N and E recordings."""
    n, e = (ref.select(channel=c)[0].data for c in ("BHN", "BHE"))
    w, v = np.linalg.eigh(np.cov(np.vstack([n, e])))
    return np.degrees(np.arctan2(v[1, 1], v[0, 1])) % 180.0


def _grid_masses(model, sig, half_deg=3.0, n=241):
    """Posterior mass (relative) within +-``half_deg`` of each mode of a
    two-angle model (two circles), by a Riemann sum of ``exp(log_prob)``."""
    from bayescal.core.orientation.geometry import unit_vector

    h = np.radians(np.linspace(-half_deg, half_deg, n))
    out = []
    for m in sig:
        centre = [b.manifold.params(unit_vector(m["channels"][b.channel_id]["azimuth_deg"], 0.0))[0]
                  for b in model.blocks]
        a, b = np.meshgrid(centre[0] + h, centre[1] + h, indexing="ij")
        lp = model.log_prob(np.column_stack([a.ravel(), b.ravel()])).reshape(a.shape)
        assert lp.max() - max(lp[[0, -1]].max(), lp[:, [0, -1]].max()) > 10   # window holds it
        out.append(lp)
    top = max(lp.max() for lp in out)
    return np.array([np.exp(lp - top).sum() for lp in out])


def test_polarised_wavefield_is_reported_bimodal(tmp_path):
    from bayescal.cli.fit import print_summary
    from bayescal.pair.workflow import calibrate
    from bayescal.io.result import write_results
    from bayescal.report.fit import load_result
    from bayescal.report.fit_pages import page_summary
    from bayescal.report.layout import ReportContext
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=10.0, seed=0, coherence=0.99, n_waves=1, diffuse=0.0,
                        sut_azimuth=(30.0, 120.0, 0.0))
    ref = sim.ref.select(channel="BH[NE]")
    # a single plane wave misfits the model's noise; the criticism is not what is tested here
    post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=ref, ref_xml=sim.ref_inventory, band=(0.02, 1.0),
                     fit_response="none", progress=False, ref_noise="quiet", diagnose=False)
    write_results(post, str(tmp_path))
    res = json.loads((tmp_path / "result.json").read_text())
    mm = res["multimodal"]
    assert mm["detected"] is True
    sig = reported.significant_modes(mm)
    d = _mirror_direction(ref)
    bh1 = "XX.SIM.10.BH1"
    found = sorted(m["channels"][bh1]["azimuth_deg"] for m in sig)
    # the truth (30) and its mirror across the ground's direction of motion
    mirror = (2 * d - 30.0) % 360.0
    assert found[0] == pytest.approx(30.0, abs=0.5)
    assert found[-1] == pytest.approx(mirror, abs=0.5) and abs(mirror - 30.0) > 20
    # measured: 69 % and 31 %, 0.85 apart in log posterior
    assert all(m["mass_fraction"] >= 0.01 for m in sig) and len(sig) == 2
    assert abs(sig[1]["log_posterior_difference"]) < np.log(100)
    # the Laplace masses against the posterior integrated on a fine grid
    # (0.025 deg) around each mode: 0.6944 / 0.3056 both ways, measured
    grid = _grid_masses(post.state.model, sig)
    assert np.allclose([m["mass_fraction"] for m in sig], grid / grid.sum(), atol=0.01)
    az = res["channels"][bh1]["azimuth_deg"]
    assert az["multimodal"] is True and "see modes" in az["note"]
    lo, hi = az["ci95"]
    assert hi - lo < 5 and not lo <= found[-1] <= hi     # one narrow interval, marked
    buf = io.StringIO()
    print_summary(res, stream=buf)
    lines = buf.getvalue().splitlines()
    assert lines[1].startswith("MULTIMODAL POSTERIOR: 2 modes") and bh1 in lines[1]
    assert "MULTIMODAL: see modes" in buf.getvalue()
    loaded = load_result(str(tmp_path))
    ctx = ReportContext(folder=str(tmp_path), post=loaded, summary=loaded.summary(), truth=None,
                        tolerance_deg=5.0)
    pages = page_summary(ctx)                # page 1, and its continuation pages
    pages = pages if isinstance(pages, list) else [pages]
    texts = [t.get_text() for fig in pages for t in fig.texts]
    assert texts[2].startswith("MULTIMODAL POSTERIOR")       # under the model check
    assert loaded.summary()["multimodal"]["detected"] is True


def test_normal_pair_is_not_flagged():
    from bayescal.cli.fit import print_summary
    from bayescal.pair.workflow import calibrate
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=10.0, seed=3, coherence=0.99,
                        sut_azimuth=(3.0, 93.0, 0.0), sut_dip=(0.0, 0.5, -89.5))
    post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.03, 1.0),
                     progress=False)
    res = post.summary()
    mm = res["multimodal"]
    assert mm["detected"] is False
    assert mm["modes"][0]["start"].startswith("closed-form")
    # every other start either came back to the first optimum or ended far below it
    assert all(m["log_mass_difference"] < -np.log(100) for m in mm["modes"][1:])
    assert not any(v.get("multimodal") for e in res["channels"].values()
                   for v in [*e.values(), *e.get("response", {}).values()] if isinstance(v, dict))
    buf = io.StringIO()
    print_summary(res, stream=buf)
    assert "MULTIMODAL" not in buf.getvalue()


def test_cowi_is_not_flagged(cowi_data):
    from bayescal.pair.workflow import calibrate_files

    d = cowi_data
    post = calibrate_files(sut=str(d / "C100823215422_COWI.LHx"), sut_xml="flat",
                           ref=[str(d / "DT000110.LH1"), str(d / "DT000110.LH2")], ref_xml="flat",
                           band=(0.125, 1 / 3), start="2010-08-24T02:00:00",
                           end="2010-08-24T13:00:00", progress=False)
    mm = post.summary()["multimodal"]
    assert mm["detected"] is False
    assert all(m["log_mass_difference"] < -np.log(100) for m in mm["modes"][1:])


def test_newton_peak_is_checked_against_the_posterior():
    """The Laplace peak extrapolated from a point far from an optimum is
    capped by the log-posterior at the Newton point: a quadratic model needs
    no cap (exact), a flat-topped one gets none of the extrapolated height."""
    a = np.array([[2.0, 0.0], [0.0, 0.5]])
    centre = np.array([1.0, -2.0])

    def quad(x):
        d = np.atleast_2d(x) - centre
        return -0.5 * np.einsum("ni,ij,nj->n", d, a, d)

    theta = np.zeros(2)
    grad, hess = modes.curvature(quad, theta, np.array([0.1, 0.1]))
    assert modes.newton_peak(quad, theta, quad(theta)[0], grad, hess) == pytest.approx(0.0,
                                                                                        abs=1e-9)

    def plateau(x):          # the same quadratic near theta, then a cliff at |x| > 0.5
        x = np.atleast_2d(x)
        return np.where(np.abs(x).max(axis=1) < 0.5, quad(x), -1e3)

    lp = plateau(theta)[0]
    assert modes.newton_peak(plateau, theta, lp, grad, hess) == lp


def test_a_stalled_start_does_not_outweigh_the_real_optimum():
    """Seeded pair 452 of ``validation/studies/eiv_coverage.py`` (1 h, coherence 0.99,
    reference noise-free, gains fitted, nominal axes of the simulator: BH1 0,
    BH2 90 against true azimuths 177.1 and 268.0). The start from the nominal
    axes stalls 527 log units below the first fit on a flat ridge of the
    per-band misfit term; its Laplace mass, extrapolated from there, was 129
    log units above the first fit's, so that point was sampled: BH1 came out
    179.95 [179.86, 180.08] at the chart's edge, without converging. Checked
    against the posterior, the stalled start weighs nothing and the first
    fit is sampled (converged, BH1 176.6 [176.2, 177.0])."""
    import bayescal
    from bayescal.simulate import harness, simulate_pair

    azs, dips, resp = harness.draw_truth(452, "gain")
    cu, cr = harness.coherences(0.99, 0)
    sim = simulate_pair(duration=3600, fs=10, seed=452, coherence=cu, ref_coherence=cr,
                        sut_azimuth=azs, sut_dip=dips, sut_response=resp,
                        nominal_response=harness.NOMINAL, noise_in_counts=True)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.02, 1.0), fit_response="gain", seed=452, progress=False,
                              ref_noise="quiet")
    s = post.summary()
    report = post.meta.multimodal
    assert report["modes"][0]["start"].startswith("closed-form") and not report["detected"]
    bh1 = s["channels"]["XX.SIM.10.BH1"]
    # the first fit's 176.7 (the truth 177.1 lies just outside this seed's 95 %
    # interval, 2.3 sd: one pair is no coverage test), not the chart's edge
    lo, hi = bh1["azimuth_deg"]["ci95"]
    assert abs(bh1["azimuth_deg"]["median"] - azs[0]) < 1.0 and hi - lo > 0.5, (azs[0], lo, hi)
    assert s["convergence"]["converged"]


def test_optimum_curvature_carries_the_pendulum_prior():
    """A 30-s sensor seen at 0.5-3 Hz with its period and damping fitted:
    the likelihood hardly fixes ``c0_rel`` (the period), so the Laplace
    curvature at an optimum must carry the pendulum prior's precision; on
    the likelihood's alone its step sizes run c0_rel out of its support and
    the curvature falls back to a near-singular information."""
    import warnings

    import bayescal
    from bayescal.core.response import pendulum
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=10.0, seed=5, coherence=0.99,
                        sut_azimuth=(3.0, 93.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                                  ref_xml=sim.ref_inventory, band=(0.5, 3.0), fit_response="all",
                                  progress=False, diagnose=False, min_ess=100, n_tau=10)
    model, theta = post.state.model, post.state.theta_ls
    opt = modes.optimum(model, theta, "test", model.noise.cholesky())
    i = model.names.index(next(n for n in model.names if n.endswith("c0_rel")))
    pr = model.priors
    prior = pendulum.prior_precision(theta[i], theta[i + 1], pr.period_tolerance,
                                     pr.damping_tolerance)[0]
    assert np.all(np.isfinite(opt.hessian)) and np.isfinite(opt.log_mass)
    assert opt.hessian[i, i] >= 0.5 * prior[0, 0], (opt.hessian[i, i], prior[0, 0])
