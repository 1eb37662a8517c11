"""The calibration report: every page exists and carries the numbers of the
saved result (read back from the PDF text with pypdf), flags follow the
simulated truth, and bad folders fail cleanly."""
import json
import os
import re
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

pypdf = pytest.importorskip("pypdf")

import bayescal  # noqa: E402
from bayescal.cli import main as cli_main  # noqa: E402
from bayescal.errors import InputError  # noqa: E402
from bayescal.io.result import save_posterior  # noqa: E402
from bayescal.report.fit import write_report  # noqa: E402
from bayescal.simulate.pair import simulate_pair  # noqa: E402

BAND = (0.03, 1.0)
# BH1 turned 12 deg from its nominal north (beyond the 5 deg tolerance), BH2
# wired with reversed polarity, BHZ tilted 0.5 deg.
TRUE_AZ = (12.0, 90.0, 0.0)
TRUE_DIP = (0.0, 0.0, -89.5)


def _fit(tmp, name, sim, ref=None, **kw):
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=ref or sim.ref, ref_xml=sim.ref_inventory,
                              band=BAND, progress=False, **kw)
    folder = str(tmp / name)
    save_posterior(post, folder)
    with open(os.path.join(folder, "truth.json"), "w") as fh:
        json.dump(sim.truth, fh)
    return folder


@pytest.fixture(scope="module")
def flagged(tmp_path_factory):
    """Orientation-only fit (gains held: --fit-response none) of a pair with
    one turned and one reversed channel."""
    sim = simulate_pair(duration=3600, fs=10, seed=4, coherence=0.99, sut_azimuth=TRUE_AZ,
                        sut_dip=TRUE_DIP, polarity_reversal=1)
    folder = _fit(tmp_path_factory.mktemp("flagged"), "result", sim, fit_response="none")
    paths = write_report(folder, png=True, full=True)
    return folder, paths


@pytest.fixture(scope="module")
def gain_fit(tmp_path_factory):
    """Fit with free gains (true gains differ from the nominal 750) against a
    two-channel horizontal reference, so BHZ is not estimable."""
    sim = simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99, sut_azimuth=(2, 91, 0),
                        sut_response=((30.0, 0.707, 790.0), (30.0, 0.707, 720.0),
                                      (30.0, 0.707, 750.0)))
    folder = _fit(tmp_path_factory.mktemp("gain"), "result", sim,
                  ref=sim.ref.select(channel="BH[NE]"), fit_response="gain")
    paths = write_report(folder, nominal_tolerance_deg=3.0, png=True, full=True)
    return folder, paths


def _pages(folder):
    reader = pypdf.PdfReader(os.path.join(folder, "report.pdf"))
    return reader, [p.extract_text() for p in reader.pages]


def _result(folder):
    with open(os.path.join(folder, "result.json")) as fh:
        return json.load(fh)


def _row(text, cid, quantity):
    """Tokens of the summary-table row of one channel and quantity."""
    for line in text.splitlines():
        if line.startswith(f"{cid} {quantity} ("):
            unit, rest = line[len(f"{cid} {quantity} "):].split(") ", 1)
            return [cid, quantity, unit + ")"] + rest.split()
    raise AssertionError(f"no table row for {cid} {quantity}:\n{text}")


def test_pages_pngs_and_metadata(flagged):
    folder, paths = flagged
    reader, pages = _pages(folder)
    # summary, intervals, corner (angles), data and fit, the response as the data
    # see it, self-noise, convergence
    assert len(pages) == 7
    assert paths[0] == os.path.join(folder, "report.pdf")
    names = sorted(os.path.basename(p) for p in paths[1:])
    assert names == sorted(f"report_{n}.png" for n in
                           ("summary", "intervals", "corner_angles", "data_fit",
                            "response_curve", "self_noise", "convergence"))
    for p in paths[1:]:
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    meta = reader.metadata
    assert "XX.SIM.10.BH1" in meta.title
    assert "band 0.03-1 Hz" in meta.subject
    assert "bayescal calibration report" in pages[0]
    assert "Angle credible intervals" in pages[1]
    assert "Posterior of the orientation angles" in pages[2]
    assert "Data and fit" in pages[3]
    assert "The SUT's response as the data see it" in pages[4]
    assert "Self-noise of both sensors" in pages[5]
    assert "Convergence of the sampler" in pages[6]
    assert not [f for f in os.listdir(folder) if f.startswith(".report")]


def test_default_report_leaves_the_sampler_pages_on_request(flagged, tmp_path):
    """Without ``full``, a fit whose sampler converged to one mode gets the
    pages an operator acts on, in order: summary, angle intervals, data and
    fit, the response as the data see it, self-noise; the corner plots and
    the convergence page only with ``full`` (the fixture's 7 pages)."""
    out = str(tmp_path / "default.pdf")
    assert write_report(flagged[0], out_pdf=out) == [out]
    titles = ["bayescal calibration report", "Angle credible intervals", "Data and fit",
              "The SUT's response as the data see it", "Self-noise of both sensors"]
    pages = [p.extract_text() for p in pypdf.PdfReader(out).pages]
    assert len(pages) == len(titles)
    assert all(t in p for t, p in zip(titles, pages)), [p[:60] for p in pages]


def test_sampler_pages_drawn_unasked_when_page_one_warns():
    """:func:`bayescal.report.fit.shown`: the convergence page when the
    sampler did not converge, the corner plots when two modes each hold at
    least the threshold's mass; every page with ``full``."""
    from bayescal.report.fit import ON_REQUEST, PAGES, shown

    calm = {"convergence": {"converged": True}, "channels": {}}
    stuck = {"convergence": {"converged": False}, "channels": {}}
    modes = {**calm, "multimodal": {"detected": True, "mass_threshold": 0.05,
                                    "modes": [{"mass_fraction": 0.7}, {"mass_fraction": 0.3}]}}
    one = {**calm, "multimodal": {"detected": True, "mass_threshold": 0.05,
                                  "modes": [{"mass_fraction": 0.98}, {"mass_fraction": 0.02}]}}
    assert [n for n in PAGES if not shown(n, calm)] == list(ON_REQUEST)
    assert [n for n in PAGES if not shown(n, one)] == list(ON_REQUEST)
    assert [n for n in PAGES if not shown(n, stuck)] == ["corner_angles", "corner_response"]
    assert [n for n in PAGES if not shown(n, modes)] == ["convergence"]
    assert all(shown(n, calm, full=True) for n in PAGES)


def test_summary_table_matches_result_and_truth(flagged):
    folder, _ = flagged
    _, pages = _pages(folder)
    res = _result(folder)
    for cid, ch in res["channels"].items():
        quantities = ["tilt", "dip"] if "tilt_deg" in ch else ["azimuth", "dip"]
        for q in quantities:
            entry = ch[f"{q}_deg"]
            tok = _row(pages[0], cid, q)
            assert tok[3] == f"{entry['median']:.2f}"
            assert " ".join(tok[4:6]) == f"[{entry['ci68'][0]:.2f}, {entry['ci68'][1]:.2f}]"
            assert " ".join(tok[6:8]) == f"[{entry['ci95'][0]:.2f}, {entry['ci95'][1]:.2f}]"
    # the printed numbers are right about the simulated sensor, not just copied
    tok = _row(pages[0], "XX.SIM.10.BH1", "azimuth")
    assert abs(float(tok[3]) - TRUE_AZ[0]) < 1.0
    assert tok[8] == "0.00"                              # nominal (StationXML)
    assert float(tok[9]) == pytest.approx(float(tok[3]), abs=0.011)   # deviation from nominal
    assert tok[10] == f"{TRUE_AZ[0]:.2f}"                # truth column
    tok = _row(pages[0], "XX.SIM.10.BHZ", "tilt")
    assert abs(float(tok[3]) - 0.5) < 0.2
    assert "window: start 2026-01-01T00:00:00" in pages[0]
    assert "duration 3600 s" in pages[0]
    m = res["meta"]
    assert f"Segments used: {m['n_segments']} of {m['n_segments_possible']}" in pages[0]
    assert "Band: 0.03 - 1 Hz" in pages[0]


#: Table labels of the report's quantities: (key in result.json, name and unit
#: as printed, printed precision).
_TABLE = {("azimuth_deg",): ("azimuth (deg)", "angle"), ("dip_deg",): ("dip (deg)", "angle"),
          ("tilt_deg",): ("tilt (deg)", "angle"),
          ("orthogonality",): ("orthogonality (deg)", "angle"),
          ("response", "gain"): ("gain (V/(m/s))", "4g"),          # the metadata's units
          ("response", "relative_gain"): ("relative gain (fitted / metadata)", "4g")}


def _printed_half_unit(value, precision):
    """Half the last printed digit of ``value``: 0.005 for angles (two
    decimals), half the fourth significant figure for responses (``.4g``)."""
    if precision == "angle":
        return 0.005
    return 0.5 * 10.0 ** (np.floor(np.log10(abs(value))) - 3)


def _table_numbers(text, key, label):
    """median, 68 % and 95 % bounds of one row of the summary table."""
    for line in text.splitlines():
        if line.startswith(f"{key} {label} "):
            tok = line[len(f"{key} {label} "):].replace("[", " ").replace("]", " ")
            return [float(t) for t in tok.replace(",", " ").split()[:5]]
    raise AssertionError(f"no table row {key} {label}:\n{text}")


@pytest.mark.parametrize("which", ["flagged", "gain_fit"])
def test_summary_table_intervals_are_those_of_the_samples(which, request):
    """Each row of the report's summary table (angles, the vertical's tilt,
    the angle between the horizontals, gains, relative gains): median, 68 %
    and 95 % interval against the percentiles of the result's samples.npz
    (16/84 and 2.5/97.5; the tilt's: the range over its 68 and 95 % lean
    regions; tests/intervals.py). Bound: half the last printed digit plus
    float rounding (a tilt region's: tests/intervals.region_tolerance)."""
    from tests.intervals import fit_samples, region_interval, tails
    folder, _ = request.getfixturevalue(which)
    _, pages = _pages(folder)
    _, samples = fit_samples(folder)
    checked = 0
    for (key, path), x in samples.items():
        if path not in _TABLE or (path == ("dip_deg",) and isinstance(x, tuple)):
            continue                          # (a vertical's dip: the table gives its tilt)
        label, precision = _TABLE[path]
        got = _table_numbers(pages[0], key, label)
        if isinstance(x, tuple):
            (ci68, tol), (ci95, tol95) = (region_interval(x[1], lab) for lab in ("ci68", "ci95"))
            want, tol = [np.median(x[2]), *ci68, *ci95], max(tol, tol95)
        else:
            want = [np.median(x), *np.percentile(x, tails("ci68")),
                    *np.percentile(x, tails("ci95"))]
            tol = 1e-9 * np.max(np.abs(want))
        for g, w in zip(got, want):
            assert abs(g - w) <= _printed_half_unit(w, precision) + tol, (key, label, got, want)
        checked += 1
    # flagged: azimuth and dip of BH1, BH2, tilt of BHZ, their angle; gain_fit:
    # azimuth of BH1, BH2 (dips held), gain and relative gain of each, their angle
    assert checked == {"flagged": 6, "gain_fit": 7}[which], checked


def _page_intervals(text):
    """(median, 68 % low, high, 95 % low, high) of each panel of the
    intervals page's text."""
    num = r"(-?\d+\.\d\d)"
    return [tuple(map(float, m)) for m in re.findall(
        rf"median {num}, 68 % \[{num}, {num}\], 95 % \[{num}, {num}\]", text)]


def _result_angles(folder):
    """(median, 68 % and 95 % bounds) of every angle result.json gives:
    azimuth, dip, or for a near-vertical channel tilt and dip."""
    out = []
    for ch in _result(folder)["channels"].values():
        for key in ("azimuth_deg", "tilt_deg", "dip_deg"):
            e = ch.get(key, {})
            if "ci95" in e and not e.get("fixed"):
                out.append((e["median"], *e["ci68"], *e["ci95"]))
    return out


def test_intervals_page_numbers_are_result_json(flagged):
    """Every interval the intervals page prints (median, 68 % and 95 % of
    each panel: azimuth, dip, the vertical's tilt and dip from its lean
    region) is result.json's, to half the last printed decimal (0.005):
    one source for every number (the vertical's tilt is not an equal-tailed
    interval of its samples, tests/intervals.py)."""
    folder, _ = flagged
    _, pages = _pages(folder)
    found = _page_intervals(pages[1])
    want = _result_angles(folder)
    assert len(found) == len(want) == 6, (found, want)
    for w in want:
        assert any(np.all(np.abs(np.subtract(f, w)) <= 0.005 + 1e-9) for f in found), (w, found)


def test_flags_follow_truth(flagged, tmp_path):
    folder, _ = flagged
    _, pages = _pages(folder)
    flags = pages[0][pages[0].index("Flags"):pages[0].index("Not estimable")]
    assert re.search(r"XX\.SIM\.10\.BH1: AZIMUTH OFF: \+1[12]\.\d\d deg", flags)
    assert re.search(r"XX\.SIM\.10\.BH2: REVERSED: axis 1[6-8]\d\.\d deg", flags)
    assert "BHZ" not in flags
    # a wider tolerance clears the turned channel but never the reversed one
    out = str(tmp_path / "wide.pdf")
    write_report(folder, out_pdf=out, nominal_tolerance_deg=20.0)
    text = pypdf.PdfReader(out).pages[0].extract_text()
    flags = text[text.index("Flags"):text.index("Not estimable")]
    assert "BH1" not in flags and "REVERSED" in flags
    assert os.listdir(tmp_path) == ["wide.pdf"]          # the PDF only: PNGs on request


def test_corner_page_states_levels_and_truth(flagged):
    _, pages = _pages(flagged[0])
    assert "Contour levels drawn: 68 % and 95 % of the 2-D posterior mass" in pages[2]
    assert "simulation truth" in pages[2]
    flat = " ".join(pages[2].split())            # labels may wrap onto two lines
    assert "BH1 azimuth (deg)" in flat
    assert "BHZ lean N (deg)" in flat


def test_data_page_numbers(flagged):
    folder, _ = flagged
    _, pages = _pages(folder)
    with np.load(os.path.join(folder, "diagnostics.npz")) as d:
        coh = d["multiple_coherence"]
        mis = d["band_misfit"]
        sut = [str(s) for s in d["sut_ids"]]
    for i, cid in enumerate(sut):
        assert f"{cid} (median coherence {np.median(coh[i]):.4f})" in pages[3]
        assert f"{cid} (median {np.median(mis[:, i]):.2f})" in pages[3]
        # the simulated sensor has coherence 0.99 with the ground
        assert 0.97 < np.median(coh[i]) < 1.0
    assert "frequency (Hz)" in pages[3]


def test_convergence_page_numbers(flagged):
    folder, _ = flagged
    _, pages = _pages(folder)
    conv = _result(folder)["convergence"]
    assert f"ESS min {conv['ess_min']:.0f}" in pages[-1]
    assert f"Acceptance fraction {conv['acceptance']:.3f}" in pages[-1]
    assert f"R-hat max {conv['rhat_max']:.4f}" in pages[-1]
    words = {"orient_a": "axis direction, 1st offset", "orient_b": "axis direction, 2nd offset",
             "azimuth_rad": "azimuth"}
    for name, p in conv["per_parameter"].items():
        cid, kind = name.rsplit(":", 1)
        label = f"{cid.split('.')[-1]} {words[kind]}"
        assert f"{label} {p['tau']:.1f} {p['ess']:.0f} {p['rhat']:.4f}" in pages[-1], label
    assert "orient_a" not in pages[-1] and "bayescal.core" not in pages[-1]


def test_response_rows_and_not_estimable(gain_fit):
    folder, paths = gain_fit
    reader, pages = _pages(folder)
    assert len(pages) == 8                       # response corner page added
    assert any(p.endswith("report_corner_response.png") for p in paths)
    assert "Posterior of the response parameters" in pages[3]
    res = _result(folder)
    for cid, true_gain in (("XX.SIM.10.BH1", 790.0), ("XX.SIM.10.BH2", 720.0)):
        g = res["channels"][cid]["response"]["gain"]
        tok = _row(pages[0], cid, "gain")
        assert tok[3] == f"{g['median']:.4g}"
        assert abs(float(tok[3]) / true_gain - 1) < 0.03
        assert f"750 {100 * (g['median'] / 750.0 - 1):+.2f} % {true_gain:.4g}" in " ".join(tok)
    assert "XX.SIM.10.BHZ: its axis lies outside the span" in pages[0]
    assert "fixed (reference plane)" in pages[0]          # circle channels: dip not estimated
    assert "Flags (tolerance 3 deg" in pages[0]


def test_cli_report_and_bad_folders(flagged, tmp_path, capsys):
    folder, _ = flagged
    assert cli_main(["report", folder, "--threshold", "20"]) == 0
    text = pypdf.PdfReader(os.path.join(folder, "report.pdf")).pages[0].extract_text()
    assert "Flags (tolerance 20 deg" in text
    missing = str(tmp_path / "nowhere")
    assert cli_main(["report", missing]) == 2
    assert missing in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="result.json is missing"):
        write_report(str(empty))
    assert os.listdir(empty) == []
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "result.json").write_text("{not json")
    (broken / "samples.npz").write_bytes(b"nope")
    with pytest.raises(InputError, match=str(broken)):
        write_report(str(broken))
    assert sorted(os.listdir(broken)) == ["result.json", "samples.npz"]


def test_rerun_without_report_removes_the_earlier_report(flagged, tmp_path):
    """A report drawn into a result folder after its run (``write_report``,
    as examples/demo.py does) is listed in the folder's manifest, so a rerun
    into the folder that writes no report (``fit --no-report``: the results
    only, published by bayescal.atomic.staging) removes the earlier
    report.pdf and PNGs; a file of the user's stays."""
    import shutil

    from bayescal.atomic import staging
    from bayescal.io.result import write_results
    from bayescal.report.fit import load_result

    folder = str(tmp_path / "fit")
    shutil.copytree(flagged[0], folder)
    for name in os.listdir(folder):                     # the fixture's own report
        if name.startswith("report"):
            os.remove(os.path.join(folder, name))
    with staging(folder) as tmp:                        # a first run: results only
        write_results(load_result(folder), tmp)
    (tmp_path / "fit" / "notes.txt").write_text("mine")
    drawn = [os.path.basename(p) for p in write_report(folder, png=True)]
    assert "report.pdf" in drawn and len(drawn) >= 6
    with staging(folder) as tmp:                        # the rerun with --no-report
        write_results(load_result(folder), tmp)
    left = set(os.listdir(folder))
    assert not left & set(drawn), sorted(left & set(drawn))
    assert {"result.json", "samples.npz", "notes.txt"} <= left


def test_single_channel_reference(tmp_path):
    """A vertical-only reference: horizontals not estimable, the vertical held
    along the reference axis with its gain fitted; no angle corner page and
    no (empty) angle-interval page."""
    sim = simulate_pair(duration=3600, fs=10, seed=6, coherence=0.99,
                        sut_response=((30.0, 0.707, 750.0), (30.0, 0.707, 750.0),
                                      (30.0, 0.707, 700.0)))
    folder = _fit(tmp_path, "z", sim, ref=sim.ref.select(channel="BHZ"), fit_response="gain")
    stale = os.path.join(folder, "report_corner_angles.png")     # from an earlier report
    open(stale, "wb").close()
    paths = write_report(folder, png=True, full=True)
    assert not os.path.exists(stale)
    _, pages = _pages(folder)
    names = [os.path.basename(p) for p in paths[1:]]
    assert "report_corner_angles.png" not in names and "report_corner_response.png" in names
    assert "report_intervals.png" not in names
    assert len(pages) == len(names) == 6          # self-noise page: not identifiable
    assert "not identifiable from one channel per sensor" in pages[-2]
    tok = _row(pages[0], "XX.SIM.10.BHZ", "dip")
    assert tok[3:5] == ["-90.00", "-"]
    assert "held along the reference axis: not estimated" in pages[0]
    for cid in ("XX.SIM.10.BH1", "XX.SIM.10.BH2"):
        assert f"{cid}: its axis lies outside the span of the 1 reference" in pages[0]
    gain = float(_row(pages[0], "XX.SIM.10.BHZ", "gain")[3])
    assert abs(gain / 700.0 - 1) < 0.03


def test_renders_without_display(flagged, tmp_path):
    """No display needed: an interactive backend and no DISPLAY still render,
    because the report never draws through pyplot."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MPLBACKEND"] = "TkAgg"
    out = str(tmp_path / "headless.pdf")
    code = ("import sys; from bayescal.report import write_report; "
            f"p = write_report({flagged[0]!r}, out_pdf={out!r}, full=True); print(len(p))")
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "1"                   # the PDF: PNGs on request
    assert len(pypdf.PdfReader(out).pages) == 7


def test_reading_a_result_imports_no_model(flagged, tmp_path):
    """Reading a stored result (``bayescal.load_posterior``, its summary,
    and ``bayescal report`` on the folder) loads no module of the model, the
    spectra, the fit or the sampler: the result stands on its own."""
    import shutil

    folder = str(tmp_path / "copy")
    shutil.copytree(flagged[0], folder)
    code = ("import sys, bayescal; "
            f"bayescal.load_posterior({folder!r}).summary(); from bayescal.cli import main; "
            f"main(['report', {folder!r}]); "
            "print(sorted(m for m in sys.modules if m.split('.')[:3] in "
            "(['bayescal', 'core', g] for g in ('model', 'spectra', 'sampling', 'fit'))))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "MPLBACKEND": "Agg"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1] == "[]"


def test_report_rebuilt_from_the_three_files(flagged, tmp_path):
    """``bayescal report`` in a fresh interpreter (no live fit) on a folder
    holding only result.json, samples.npz and diagnostics.npz prints the
    numbers result.json holds: the azimuth table row on page 1 and the
    convergence figures on the last page."""
    import shutil

    folder = tmp_path / "files_only"
    folder.mkdir()
    for name in ("result.json", "samples.npz", "diagnostics.npz"):
        shutil.copy(os.path.join(flagged[0], name), folder / name)
    run = subprocess.run([sys.executable, "-m", "bayescal", "report", str(folder), "--full"],
                         capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
    assert run.returncode == 0, run.stderr
    res = _result(str(folder))
    _, pages = _pages(str(folder))
    entry = res["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    tok = _row(pages[0], "XX.SIM.10.BH1", "azimuth")
    assert tok[3] == f"{entry['median']:.2f}" and abs(entry["median"] - TRUE_AZ[0]) < 1.0
    assert " ".join(tok[6:8]) == f"[{entry['ci95'][0]:.2f}, {entry['ci95'][1]:.2f}]"
    conv = res["convergence"]
    assert f"ESS min {conv['ess_min']:.0f}" in pages[-1]
    assert f"R-hat max {conv['rhat_max']:.4f}" in pages[-1]


def test_unconverged_and_missing_diagnostics(flagged, tmp_path):
    """A result whose sampler did not converge says so on pages 1 and 5; a
    result without diagnostics.npz still renders, saying what is missing."""
    from bayescal.io.result import load_posterior

    post = load_posterior(flagged[0])
    post = replace(post, convergence=replace(post.convergence, converged=False), diagnostics={})
    folder = str(tmp_path / "unconverged")
    save_posterior(post, folder)
    assert not os.path.exists(os.path.join(folder, "diagnostics.npz"))
    write_report(folder)                     # the convergence page drawn unasked
    _, pages = _pages(folder)
    assert "SAMPLER NOT CONVERGED" in pages[0]
    assert "converged: NO" in pages[0] and "Convergence of the sampler" in pages[-1]
    assert "converged: NO" in pages[-1]
    assert any("no diagnostics.npz in the result folder" in p for p in pages)
    assert "SAMPLER NOT CONVERGED" not in _pages(flagged[0])[1][0]
