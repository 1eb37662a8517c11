"""One page size throughout every PDF (issue 14 item 11): A4 by default,
US Letter with ``--paper letter``; every page of the fit report (whose
interval and corner pages are drawn smaller than a page), diagnosis.pdf, the
batch report, and the cal and uvw reports (landscape) has the same mediabox.
A4 is 595 x 842 pt, Letter 612 x 792 pt."""
from __future__ import annotations

import csv
import types

import numpy as np
import pytest

pypdf = pytest.importorskip("pypdf")

A4_PT, LETTER_PT = (595.44, 841.68), (612.0, 792.0)


def mediaboxes(path):
    """(width, height) in points of every page of the PDF at ``path``."""
    return [(round(float(p.mediabox.width), 2), round(float(p.mediabox.height), 2))
            for p in pypdf.PdfReader(str(path)).pages]


@pytest.fixture(scope="module")
def gain_result(tmp_path_factory):
    """A fit with free gains (so the report has a response corner page too)."""
    import bayescal
    from bayescal.io.result import save_posterior
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800, fs=10, seed=5, coherence=0.99, sut_azimuth=(2, 91, 0))
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.03, 1.0), progress=False, fit_response="gain")
    folder = tmp_path_factory.mktemp("paper") / "result"
    save_posterior(post, str(folder))
    return folder


def test_fit_report_one_page_size(gain_result, tmp_path):
    from bayescal.cli import main
    from bayescal.report.fit import write_report

    # the command line: A4 unless told
    assert main(["report", str(gain_result), "--full"]) == 0
    boxes = mediaboxes(gain_result / "report.pdf")
    assert len(boxes) == 8 and set(boxes) == {A4_PT}, boxes   # with the self-noise page
    out = tmp_path / "report.pdf"
    write_report(str(gain_result), out_pdf=str(out), paper="letter", full=True)
    boxes = mediaboxes(out)
    assert len(boxes) == 8 and set(boxes) == {LETTER_PT}, boxes


def _stub_diagnosis(n_ch=4, n_b=8):
    """What write_page reads of a Diagnosis: four channels (an eight-entry
    legend on each axes)."""
    edges = np.geomspace(0.02, 2.0, n_b + 1)
    mis = np.geomspace(0.5, 5e4, n_b)[:, None] * np.ones(n_ch)
    ratio = np.exp(1j * np.linspace(0, 0.3, n_b))[:, None] * np.ones(n_ch)
    base = object()
    return types.SimpleNamespace(
        band_edges=edges, ids=[f"XX.SIM.10.BH{c}" for c in "NEZ1"[:n_ch]],
        sentences=lambda: ["the SUT's clock is 0.498 s late; modelling it lowers the misfit"],
        before={"mismatch": []}, before_common={"misfit": mis}, after={"misfit": mis / 100},
        ratio_before=ratio, ratio_after=ratio, base=base, final=object())


@pytest.mark.parametrize("paper, size", [("a4", A4_PT), ("letter", LETTER_PT)])
def test_diagnosis_page_size(tmp_path, paper, size):
    from bayescal.report.diagnosis import write_page

    pdf, png = write_page(_stub_diagnosis(), str(tmp_path / "diagnosis"), paper=paper)
    assert mediaboxes(pdf) == [size]


def test_batch_report_one_page_size(tmp_path):
    from bayescal.report.batch import COLUMNS, write_report

    rows = []
    for s in range(7):   # two pages of stations after the text page
        for day in ("2026-01-01", "2026-01-02"):
            for cha, az in (("BHN", 0.0), ("BHE", 90.0)):
                rows.append({"label": f"S{s}_{day}", "station": f"XX.S{s}", "day": day,
                             "channel": f"XX.S{s}.10.{cha}", "kind": "circle", "azimuth": az + s,
                             "azimuth_lo95": az + s - 0.2, "azimuth_hi95": az + s + 0.2,
                             "nominal_azimuth": az, "dip": 0.0, "dip_lo95": -0.1,
                             "dip_hi95": 0.1, "nominal_dip": 0.0, "ess_min": 1200,
                             "tau_max": 20, "rhat_max": 1.001, "converged": "True"})
    path = tmp_path / "results.csv"
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    out = write_report(str(path), str(tmp_path))
    boxes = mediaboxes(out["pdf"])
    assert len(boxes) == 3 and set(boxes) == {A4_PT}, boxes


def test_vertical_only_sut_has_no_empty_intervals_page(tmp_path):
    """Issue 14 item 12: a vertical against a vertical (response fitted, no
    angle estimated) gets no 'Angle credible intervals' page."""
    import bayescal
    from bayescal.report.fit import write_report
    from bayescal.io.result import save_posterior
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800, fs=10, seed=7, coherence=0.99)
    post = bayescal.calibrate(sut=sim.sut.select(channel="BHZ"), sut_xml=sim.sut_inventory,
                              ref=sim.ref.select(channel="BHZ"), ref_xml=sim.ref_inventory,
                              band=(0.03, 1.0), progress=False, fit_response="gain")
    folder = tmp_path / "z"
    save_posterior(post, str(folder))
    paths = write_report(str(folder), full=True)
    texts = [p.extract_text() for p in pypdf.PdfReader(paths[0]).pages]
    assert not any("Angle credible intervals" in t for t in texts)
    assert not (folder / "report_intervals.png").exists()
    # summary, response corner, data and fit, the response as the data see it,
    # self-noise (not identifiable from one channel a side, said on the page),
    # convergence; all one size
    assert len(texts) == 6 and set(mediaboxes(paths[0])) == {A4_PT}
    assert any("not identifiable" in t for t in texts)
