"""Every report figure lays out cleanly: rendered once (Agg) at the
report's page size, no text falls off the page, no table text leaves its
cell, no legend sits over a curve and no legend names a curve the axes do
not show (tests/figures.py, from matplotlib's tight bounding boxes). A
failing fit's page 1 continues on a second page rather than losing its
flags and notes.

Time budget: the checks of one figure (one Agg rendering at 72 dpi, then
the boxes) take under 10 s, asserted per figure; measured 0.5-4 s a page
on the shared two-core test machine under load, mostly the rendering of
text.
"""
from __future__ import annotations

import glob
import json
import os
import pathlib
import time
import warnings

import numpy as np
import pytest
from matplotlib.text import Text

from tests.figures import layout_faults

pypdf = pytest.importorskip("pypdf")

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: Seconds one figure's rendering and checks may take.
BUDGET_S = 10.0


def _clean(fig, name):
    t0 = time.perf_counter()
    faults = layout_faults(fig)
    spent = time.perf_counter() - t0
    assert faults == [], (name, faults)
    assert spent < BUDGET_S, (name, spent)


@pytest.fixture(scope="module")
def failing(tmp_path_factory):
    """A fit whose model check fails (the SUT's clock 0.3 s late), with the
    criticism's improved model heading the result, BH1 turned 12 deg and
    BHZ tilted 8 deg from its nominal vertical: page 1 carries a long
    criticism, an AZIMUTH OFF and a TILT OFF flag."""
    import bayescal
    from bayescal.io.result import save_posterior
    from bayescal.report.fit import write_report
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800, fs=10, seed=2, coherence=0.99, timing_offset_s=0.3,
                        sut_azimuth=(12.0, 90.0, 0.0), sut_dip=(0.0, 0.0, -82.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                                  ref_xml=sim.ref_inventory, band=(0.03, 1.0), progress=False,
                                  min_ess=200, n_tau=20, fit_response="gain")
    folder = str(tmp_path_factory.mktemp("failing") / "fit")
    save_posterior(post, folder)
    return folder, write_report(folder)


def test_failing_fit_page_one_continues(failing):
    """Page 1's flags (the BHZ TILT OFF line), "Not estimable" and the
    notes all reach the PDF: what does not fit on page 1 goes on to a page
    "page 1 continued", in order."""
    folder, paths = failing
    res = json.loads(pathlib.Path(folder, "result.json").read_text())
    assert res["adequacy"]["ok"] is not None and res["criticism"]["verdict"] == "improved"
    pages = [p.extract_text() for p in pypdf.PdfReader(paths[0]).pages]
    assert "page 1 continued" in pages[1]
    text = " ".join(" ".join(pages[:2]).split())
    order = ["Flags (tolerance 2 deg", "XX.SIM.10.BH1: AZIMUTH OFF: +1", "XX.SIM.10.BHZ: TILT OFF: +",
             "Not estimable: none", "Intervals are equal-tailed", "Gain: first-stage sensitivity"]
    at = [text.find(s) for s in order]
    assert all(a >= 0 for a in at) and at == sorted(at), list(zip(order, at))
    tilt = res["channels"]["XX.SIM.10.BHZ"]["tilt_deg"]["median"]
    assert f"XX.SIM.10.BHZ: TILT OFF: {tilt:+.2f} deg" in text


def _fit_figures(folder):
    from bayescal.report import fit, layout
    from bayescal.report.tables import load_truth

    post = fit.load_result(folder)
    ctx = layout.ReportContext(folder=folder, post=post, summary=post.summary(),
                               truth=load_truth(folder, post.meta), tolerance_deg=5.0)
    return fit.figures(ctx)


def test_fit_report_figures_lay_out_cleanly(failing):
    from bayescal.report.layout import style

    with style():
        names = []
        for name, fig in _fit_figures(failing[0]):
            _clean(fig, name)
            names.append(name)
    assert {"summary", "summary_2", "intervals", "data_fit", "self_noise", "convergence",
            "rejected_fit"} <= set(names), names


def test_flow_text_keeps_every_line_in_order():
    """flow_text: 150 numbered lines from mid-page run on to as many
    continuation pages as they need, each line once, in order, none below
    the bottom margin."""
    from matplotlib.figure import Figure

    from bayescal.report.layout import A4, BOTTOM, flow_text, text_extent

    lines = [f"line {k:03d}" for k in range(150)]
    figs = flow_text(Figure(figsize=A4), 0.06, 0.5, lines,
                     lambda: (Figure(figsize=A4), 0.94), fontsize=8, linespacing=1.5)
    assert len(figs) == 3                # about 33 lines on the half page, 64 on a full one
    got = [ln for f in figs for t in f.texts for ln in t.get_text().split("\n")]
    assert got == lines
    for f in figs:
        for t in f.texts:
            assert text_extent(f, t)[1] >= BOTTOM - 1e-9
        _clean(f, "flow")


def test_noise_page_lays_out_cleanly():
    """The self-noise page of three co-located sensors, one quiet below
    resolution over part of the band: NLNM and NHNM are on the axes they
    are named on, the legend beside the curves, the caption on the page."""
    from bayescal.core.selfnoise import SelfNoise
    from bayescal.io.noise import ComponentNoise
    from bayescal.report.layout import style
    from bayescal.report.noise import figure_component

    f = np.logspace(-2, 1, 40)
    ground = 10 ** (-13.5) * (1 + (f / 0.2) ** -2)
    noise = np.array([1e-16, 3e-16, 1e-18]) [:, None] * np.ones_like(f)
    psd = noise.copy()
    lo, hi = 0.5 * noise, 2 * noise
    psd[2, 10:20], lo[2, 10:20], hi[2, 10:20] = np.nan, 0.0, 1e-15
    est = SelfNoise(freqs=f, psd=psd, lo=lo, hi=hi, dof=np.full_like(f, 50.0), level=0.9,
                    method="bootstrap", signal=ground + noise,
                    pair_range=np.stack([psd, psd], axis=-1),
                    ids=["II.XPFO.00.BHZ", "II.XPFO.10.BHZ", "II.XPFO.60.BHZ"])
    comp = ComponentNoise("Z", est.ids, est, 4096, 30, 0.97, (0.01, 10.0))
    with style():
        _clean(figure_component(comp), "noise_Z")


@pytest.mark.parametrize("path", sorted(glob.glob(str(ROOT / "reports" / "diagnose" / "*"
                                                            / "diagnosis.json"))))
def test_diagnosis_pages_lay_out_cleanly(path):
    """The diagnosis page of each stored diagnosis (reports/diagnose)."""
    from bayescal.criticism.diagnosis import SavedDiagnosis
    from bayescal.report.diagnosis import build_figure
    from bayescal.report.layout import style

    with style():
        _clean(build_figure(SavedDiagnosis(json.loads(pathlib.Path(path).read_text()))),
               os.path.basename(os.path.dirname(path)))


def _coil_run(tmp, argv):
    from bayescal.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([str(a) for a in argv]) == 0


def test_cal_pages_lay_out_cleanly(tmp_path):
    """The pages of a random coil calibration: in the report's style, with
    the sampler and the model check in words (no raw keys), the gain's
    units on the corner plot."""
    from bayescal.report.cal import PAGES, read_folder
    from bayescal.report.layout import style
    from bayescal.simulate.cal import simulate_random_cal

    simulate_random_cal(truth=(121.0, 0.72, 1510.0), duration=1800, fs=5,
                        seed=1).write(str(tmp_path / "run"))
    out = tmp_path / "cal"
    _coil_run(tmp_path, ["cal", "--cal", tmp_path / "run" / "cal_cal.mseed", "--input-channel",
                         "BC0", "--output-channel", "MHZ", "--sut-xml",
                         tmp_path / "run" / "sut.xml", "--coil-constant", "1e-9", "--out", out,
                         "--quiet"])
    summary, arrays = read_folder(str(out))
    with style():
        for name, make in PAGES[summary["kind"]]:
            fig = make(summary, arrays)
            _clean(fig, name)
            text = " ".join(t.get_text() for t in fig.findobj(Text))
            assert "n_steps" not in text and "converged True" not in text, name
    assert "gain (V/(m/s))" in text                       # the corner page's axis


def test_uvw_pages_lay_out_cleanly(tmp_path):
    """The three UVW pages: bands and table at one level (95 %), table
    text inside its cells, legends beside the curves."""
    from bayescal.report.layout import style
    from bayescal.report.uvw import agreement_page, elements_page, xyz_page
    from bayescal.simulate.coil import simulate_calibration

    simulate_calibration(seed=7, duration=2 * 3600.0, coil_constant=1e-9).write(
        str(tmp_path / "in"))
    out = tmp_path / "uvw"
    _coil_run(tmp_path, ["uvw", *[f"--cal={e}={tmp_path / 'in' / f'cal_{e}.mseed'}"
                                  for e in "UVW"],
                         "--input-channel", "BC0", "--coil-constant", "1e-9", "--sensor", "sts2",
                         "--sut-xml", tmp_path / "in" / "sut.xml", "--out", out, "--band",
                         "0.0042", "0.1", "--quiet"])
    summary = json.loads((out / "uvw.json").read_text())
    with np.load(out / "uvw_samples.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    with style():
        for make in (elements_page, xyz_page, agreement_page):
            fig = make(summary, arrays)
            _clean(fig, make.__name__)
            text = " ".join(t.get_text() for t in fig.findobj(Text))
            assert "90 %" not in text and "diag(" not in text and "T_lm" not in text
