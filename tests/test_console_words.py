"""Plain words on the console: what ``bayescal fit``, ``diagnose``, ``noise``
and ``cal`` print says what it means for the user's numbers, and leaves the
statistics to the documentation page it names.

The commands run as a user runs them (subprocesses, progress on) on small
simulated data; the lines that appear only in rarer cases (a failed model
check, a multimodal posterior, a short record) are built from the same
functions the console calls. Every documentation page a line names must
exist.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable

#: Words a user should not have to know to read the console: statistical
#: machinery that belongs on the documentation page the line names.
BANNED = ["family-wise", "familywise", "band-channel", "cells", "Laplace", "plug-in", "plugin",
          "Bonferroni", "Mahalanobis", "Wishart", "Birge", "dBIC", "delta BIC", "inverse-gamma",
          "InverseGamma", "Gamma(", "chi2", "whitened", "tempered", "profile likelihood",
          "Hessian", "Fisher information", "log mass"]
BANNED_RX = re.compile("|".join(re.escape(w) for w in BANNED), re.IGNORECASE)
DOCS_RX = re.compile(r"docs/[\w/]+\.md")


def _check(text, what):
    hits = sorted({m.group(0) for m in BANNED_RX.finditer(text)})
    assert not hits, f"{what} uses {hits}:\n{text}"
    for page in DOCS_RX.findall(text):
        assert (ROOT / page).is_file(), f"{what} names {page}, which does not exist"


def _run(*args, cwd):
    proc = subprocess.run([PY, "-m", "bayescal.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=600, cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout + proc.stderr


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    from bayescal import simulate_pair
    from bayescal.simulate.cal import simulate_random_cal
    from bayescal.simulate.selfnoise import simulate_colocated

    root = tmp_path_factory.mktemp("console")
    out = {"root": root}
    out["pair"] = simulate_pair(duration=1800.0, fs=10.0, seed=1, coherence=0.99,
                                sut_azimuth=(3.0, 93.0, 0.0)).write(str(root / "pair"))
    out["late"] = simulate_pair(duration=1800.0, fs=10.0, seed=2, coherence=0.99,
                                timing_offset_s=0.3).write(str(root / "late"))
    out["three"] = simulate_colocated(duration=3600.0, fs=10.0, seed=0).write(str(root / "three"))
    out["cal"] = simulate_random_cal(truth=(121.0, 0.72, 1510.0), duration=3600.0, fs=5.0,
                                     seed=1).write(str(root / "cal"))
    return out


def _pair_args(f):
    return ["--ref", f["ref.mseed"], "--ref-xml", f["ref.xml"], "--sut", f["sut.mseed"],
            "--sut-xml", f["sut.xml"]]


def test_fit_console(data):
    text = _run("fit", *_pair_args(data["pair"]), "--out", "fit", "--band", 0.03, 1,
                "--no-report", cwd=data["root"])
    assert "model check: passed" in text
    _check(text, "bayescal fit")


def test_fit_console_when_the_model_does_not_fit(data):
    """The criticism's block (a concealed 0.3 s clock offset): plain words,
    the verdict last."""
    text = _run("fit", *_pair_args(data["late"]), "--out", "fit_late", "--band", 0.03, 1,
                "--no-report", cwd=data["root"])
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert "found: the SUT's clock is 0.3 s late" in text
    assert any(ln.startswith("verdict: ") and "timing offset" in ln for ln in lines)
    _check(text, "bayescal fit (criticism)")


def test_diagnose_console(data):
    text = _run("diagnose", *_pair_args(data["late"]), "--out", "diag", "--band", 0.03, 1,
                "--no-report", cwd=data["root"])
    assert "timing offset" in text and "BIC gain" in text
    _check(text, "bayescal diagnose")


def test_noise_console(data):
    d, x = data["three"]
    text = _run("noise", "--data", *d, "--xml", *x, "--out", "noise", cwd=data["root"])
    assert "self-noise" in text
    _check(text, "bayescal noise")


def test_cal_console(data):
    c = data["cal"]
    text = _run("cal", "--cal", c["cal"], "--input-channel", "BC0", "--output-channel", "MHZ",
                "--sut-xml", c["xml"], "--coil-constant", 1e-9, "--out", "cal", cwd=data["root"])
    assert "model check" in text
    _check(text, "bayescal cal")


def test_rarer_console_lines():
    """The lines of a failed model check, a multimodal posterior and a short
    record, from the functions the console prints them with."""
    from bayescal.core.checks.adequacy import adequacy, describe
    from bayescal.core.posterior.modes import describe as modes_line
    from bayescal.core.checks import record_length_entry

    misfit = np.ones((6, 3))
    misfit[-1, 1] = 40.0
    verdict = adequacy(misfit, np.geomspace(0.02, 1.0, 7), ["A.B.10.BH1", "A.B.10.BH2",
                                                           "A.B.10.BHZ"], 3)
    failed = describe(verdict)
    assert failed.startswith("MODEL DOES NOT FIT THE DATA") and "bayescal diagnose" in failed
    assert "A.B.10.BH2" in failed and "docs/" in failed
    report = {"detected": True, "mass_threshold": 0.01,
              "modes": [{"mass_fraction": 0.69}, {"mass_fraction": 0.31}]}
    multi = modes_line(report, {"A.B.10.BH1": ["azimuth_deg"]})
    assert multi.startswith("MULTIMODAL POSTERIOR: 2 modes") and "docs/" in multi
    short = record_length_entry(900.0, 0.02)["note"]
    assert "short record for the band" in short
    for text, what in [(failed, "failed model check"), (multi, "multimodal line"),
                       (short, "short-record note")]:
        _check(text, what)
