"""The reports of ``bayescal cal``, ``uvw`` and ``noise`` are rebuilt from
their output folder alone: each command runs through the command line (no
fit object outlives it: ``main`` returns only the exit code), its figures
are deleted, and ``bayescal report DIR`` draws them again from the JSON and
npz files; numbers on the redrawn pages and in the saved figure data are
those of the JSON."""
from __future__ import annotations

import json
import numpy as np
import pytest

pypdf = pytest.importorskip("pypdf")

def _bayescal(*argv):
    """``bayescal ARGV``; returns the exit code."""
    from bayescal.cli import main

    return main([str(a) for a in argv])


def _redraw(out, figures):
    """Delete the figures, redraw them with ``bayescal report``; the PDF's text."""
    for name in figures:
        (out / name).unlink()
    assert _bayescal("report", out) == 0
    assert all((out / name).exists() for name in figures)
    pdf = next(name for name in figures if name.endswith(".pdf"))
    return "\n".join(p.extract_text() for p in pypdf.PdfReader(str(out / pdf)).pages)


def test_cal_report_rebuilt_from_its_folder(tmp_path):
    from bayescal.simulate.cal import simulate_random_cal

    simulate_random_cal(truth=(121.0, 0.72, 1510.0), duration=3600, fs=5,
                        seed=1).write(str(tmp_path / "run"))
    out = tmp_path / "cal"
    assert _bayescal("cal", "--cal", tmp_path / "run" / "cal_cal.mseed", "--input-channel", "BC0",
                     "--output-channel", "MHZ", "--sut-xml", tmp_path / "run" / "sut.xml",
                     "--coil-constant", "1e-9", "--out", out, "--quiet") == 0
    text = _redraw(out, ["cal_report.pdf", "cal_response.png", "cal_residuals.png",
                         "cal_corner.png"])
    p = json.loads((out / "cal.json").read_text())["parameters"]
    e = p["period_s"]
    assert (f"period: {e['median']:.6g}  95 % [{e['ci95'][0]:.6g}, {e['ci95'][1]:.6g}] s"
            in text)
    assert "n_steps" not in text and "converged True" not in text      # words, not keys
    assert "converged: yes" in text
    with np.load(out / "cal_samples.npz") as npz:
        corner = npz["corner_samples"]
        assert list(npz["corner_labels"][:3]) == ["period (s)", "damping", "gain"]
        # the corner page's period and gain columns are the samples cal.json summarises
        assert np.median(corner[:, 0]) == pytest.approx(e["median"], rel=1e-12)
        assert np.median(corner[:, 2]) == pytest.approx(p["gain"]["median"], rel=1e-12)
        # the fitted curve's median ratio at the normalisation frequency (1 Hz) is
        # the fitted over the nominal gain
        f, amp = npz["curve_freqs"], npz["curve_amp"][1]
        assert np.interp(0.0, np.log(f), amp) == pytest.approx(p["gain"]["median"] / 1500.0,
                                                               rel=2e-3)


def test_uvw_report_rebuilt_from_its_folder(tmp_path):
    from bayescal.simulate.coil import simulate_calibration

    simulate_calibration(seed=7, duration=2 * 3600.0, coil_constant=1e-9).write(
        str(tmp_path / "in"))
    runs = [f"--cal={e}={tmp_path / 'in' / f'cal_{e}.mseed'}" for e in "UVW"]
    out = tmp_path / "uvw"
    assert _bayescal("uvw", *runs, "--input-channel", "BC0", "--coil-constant", "1e-9",
                     "--sensor", "sts2", "--sut-xml", tmp_path / "in" / "sut.xml", "--out", out,
                     "--band", "0.0042", "0.1", "--quiet") == 0
    text = _redraw(out, ["uvw_report.pdf", "uvw_elements.png", "uvw_xyz.png",
                         "uvw_agreement.png"])
    s = json.loads((out / "uvw.json").read_text())
    ct = s["cross_talk_max"]
    assert f"largest cross-talk {100 * ct['median']:.3g} %" in text
    assert f"{s['elements']['V']['period_s']['median']:.5g}" in text
    with np.load(out / "uvw_samples.npz") as npz:
        assert np.median(npz["element_V"][:, 0]) == pytest.approx(
            s["elements"]["V"]["period_s"]["median"], rel=1e-12)


def test_noise_report_rebuilt_from_its_folder(tmp_path):
    from bayescal.simulate.selfnoise import simulate_colocated

    data, xml = simulate_colocated(1800.0, 10.0, seed=5).write(str(tmp_path / "in"))
    out = tmp_path / "noise"
    assert _bayescal("noise", "--data", *data, "--xml", *xml, "--out", out, "--quiet",
                     "--band", "0.01", "4", "--n-boot", "100") == 0
    text = _redraw(out, ["noise.pdf", "noise_Z.png"])
    doc = json.loads((out / "noise.json").read_text())
    seg = doc["meta"]["segments"]["Z"]
    assert f"{seg['n_segments']} Hann segments of {seg['nperseg']} samples" in text
    # the table's row nearest 1 s: each sensor's estimate, as noise.json has it (to 0.01 dB)
    lines = text.splitlines()
    rows = [line.split() for line in lines[lines.index(next(x for x in lines
                                                            if x.split()[:2] == ["period", "s"]))
                                            + 1:]]
    rows = [r for r in rows if r and r[0].replace(".", "").isdigit()]
    row = min(rows, key=lambda r: abs(np.log(float(r[0]))))
    shown = [float(w.strip("[],")) for w in row[1:] if w.strip("[],").lstrip("-")
             .replace(".", "").isdigit()]
    checked = 0
    for e in doc["sensors"].values():
        b = int(np.argmin(np.abs(np.log(np.array(e["period_s"]) / float(row[0])))))
        if e["psd_db"][b] is not None and not e["below_resolution"][b]:
            assert any(abs(v - e["psd_db"][b]) <= 0.051 for v in shown), (row, e["psd_db"][b])
            checked += 1
    assert checked >= 2
