"""Reports from files: the diagnosis page and the batch report are rebuilt
from what their run wrote (``diagnosis.json``; the batch folder's item
folders), in a fresh interpreter holding no live object of the run, and
the rebuilt page states the numbers the files hold."""
import glob
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pypdf
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def late_fit():
    """A short fit of a pair whose SUT clock is 0.3 s late (the diagnosis
    names a timing offset), without its criticism."""
    import warnings

    import bayescal
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800, fs=10, seed=2, coherence=0.99, timing_offset_s=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                                  ref_xml=sim.ref_inventory, band=(0.05, 3.0), progress=False,
                                  min_ess=200, n_tau=20, fit_response="gain", ref_noise="quiet",
                                  diagnose=False)


def _fresh(code, *args):
    """Run ``code`` in a new interpreter (nothing of this process's run in it)."""
    subprocess.run([sys.executable, "-c", code, *map(str, args)], check=True, cwd=str(ROOT),
                   capture_output=True, text=True)


def _pdf_text(path):
    """The first page's text, its white space as single spaces (the page
    wraps its lines at spaces)."""
    return " ".join(pypdf.PdfReader(str(path)).pages[0].extract_text().split())


def _drawn(fig):
    return [line.get_ydata() for ax in fig.axes for line in ax.get_lines()]


def test_diagnosis_page_rebuilt_from_its_json(late_fit, tmp_path):
    from bayescal.criticism.diagnose import diagnose
    from bayescal.criticism.diagnosis import SavedDiagnosis
    from bayescal.io.result import write_json
    from bayescal.report.diagnosis import build_figure

    d = diagnose(late_fit.state, mcmc=False)
    path = tmp_path / "diagnosis.json"
    write_json(str(path), d.summary())
    live = build_figure(d)
    live_text, live_lines = [t.get_text() for t in live.texts], _drawn(live)
    del d, live
    doc = json.loads(path.read_text())
    assert [e["name"] for e in doc["effects"]] == ["timing_offset"]
    # the page from the file alone: the same words and the same curves
    rebuilt = build_figure(SavedDiagnosis(doc))
    assert [t.get_text() for t in rebuilt.texts] == live_text
    assert "timing offset" in " ".join(live_text[1].split())       # the findings, in words
    lines = _drawn(rebuilt)
    assert len(lines) == len(live_lines)
    for a, b in zip(lines, live_lines):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    # the first curve is the first channel's misfit before (the fit's own
    # check), as the file holds it
    np.testing.assert_array_equal(
        lines[0], np.asarray(doc["per_band"]["check_before"]["misfit"])[:, 0])
    # and the page written by a fresh interpreter states the file's BIC gain
    _fresh("import json, sys\n"
           "from bayescal.criticism.diagnosis import SavedDiagnosis\n"
           "from bayescal.report.diagnosis import write_page\n"
           "with open(sys.argv[1]) as fh:\n"
           "    write_page(SavedDiagnosis(json.load(fh)), sys.argv[2])\n",
           path, tmp_path / "rebuilt")
    gain = doc["effects"][0]["score_gain"]
    assert f"(BIC gain {gain:.0f})" in _pdf_text(tmp_path / "rebuilt.pdf")


REBUILD_BATCH = """
import glob, json, os, sys
from bayescal.report.batch import results_table, write_report
out = sys.argv[1]
items = []
for path in sorted(glob.glob(os.path.join(out, "*", "item.json"))):
    with open(path) as fh:
        items.append(json.load(fh))
write_report(results_table(items, out), out)
"""


def test_batch_report_rebuilt_from_the_folder(late_fit, tmp_path):
    """A batch folder of two items (each as ``run_item`` publishes it:
    result.json, samples.npz, item.json): its table and report, deleted,
    come back the same from the folder alone, and the report states the
    table's smallest ESS."""
    from bayescal.io.result import save_posterior, write_json
    from bayescal.report.batch import read_results, results_table, write_report

    out = tmp_path / "batch"
    items = []
    for k, day in enumerate(("2026-01-01", "2026-01-02")):
        item = {"label": f"XX.SIM_{day}", "kind": "sds", "network": "XX", "station": "SIM",
                "day": day}
        folder = out / item["label"]
        save_posterior(late_fit, str(folder))
        write_json(str(folder / "item.json"), item)
        items.append(item)
        if k:       # the second day's chain twice as long: the smallest ESS is the first's
            res = json.loads((folder / "result.json").read_text())
            res["convergence"]["ess_min"] *= 2
            write_json(str(folder / "result.json"), res)
    write_report(results_table(items, str(out)), str(out))
    written = {name: (out / name).read_text() for name in ("results.csv", "flags.csv")}
    for name in ("results.csv", "flags.csv", "report.pdf", "report.png"):
        os.remove(out / name)
    _fresh(REBUILD_BATCH, out)
    for name, text in written.items():
        assert (out / name).read_text() == text, name
    assert (out / "report.png").stat().st_size > 0
    rows = read_results(str(out / "results.csv"))
    ess = min(r["ess_min"] for r in rows)
    first = sorted(glob.glob(str(out / "*" / "result.json")))[0]
    with open(first) as fh:
        assert ess == json.load(fh)["convergence"]["ess_min"]
    assert f"min ESS {ess:.0f}," in _pdf_text(out / "report.pdf")
