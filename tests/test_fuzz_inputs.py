"""Corrupted inputs end in one line and exit code 2, or in a complete run.

A small simulated pair (10 minutes at 10 Hz) is written as miniSEED and
StationXML, and each case corrupts one of the four files (reference or SUT,
StationXML or miniSEED) before ``bayescal fit`` runs on them:

* malformed metadata values, on both sides: sensitivity, stage gain, pole,
  zero, normalisation factor, azimuth, dip, sample rate and decimation
  values written as text, NaN, INF or nothing. Each must be refused (exit
  2) with one line naming the StationXML file and the channel;
* seeded truncations and single-bit flips of the StationXML and miniSEED
  files (half of the miniSEED flips in the first record's header).

For every case: no exception escapes, stderr holds no traceback and, on exit
2, exactly one line (``bayescal: error: ...``), and the output folder either
does not exist (exit 2, no staging folder left beside it) or holds the
complete result (exit 0: result.json that parses, samples.npz,
diagnostics.npz, sut_corrected.xml). ``bayescal noise`` refuses a malformed
sensitivity the same way.
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from bayescal.cli import main

FILES = ("sut.xml", "ref.xml", "sut.mseed", "ref.mseed")
FIT = ["--quiet", "--no-report", "--band", "0.05", "1"]


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The clean files' bytes (a pair that fits in well under a second)."""
    from bayescal.simulate.pair import simulate_pair

    folder = tmp_path_factory.mktemp("fuzz_pair")
    simulate_pair(duration=600.0, fs=10.0, seed=1).write(str(folder))
    return {name: (folder / name).read_bytes() for name in FILES}


#: (element, occurrence) of the values broken, and how.
VALUES = [(r"InstrumentSensitivity>\s*<Value", "abc"), (r"StageGain>\s*<Value", "NaN"),
          ("Real", "x"), ("Imaginary", "INF"), ("NormalizationFactor", ""),
          ("Azimuth", "north"), ("Dip", "NaN"), ("SampleRate", "ten"),
          ("InputSampleRate", "q"), ("Factor", "1e400")]


def _break_value(text, where, bad, k):
    """``text`` with the k-th (cyclically) value of element ``where`` replaced by ``bad``."""
    tag = where.rsplit("<", 1)[-1]
    hits = list(re.finditer(rf"(?:{where})(?: [^>]*)?>([^<]*)</{tag}>", text))
    m = hits[k % len(hits)]
    return text[:m.start(1)] + bad + text[m.end(1):]


def _cases(pair):
    rng = np.random.default_rng(20240611)
    for side in ("sut.xml", "ref.xml"):
        text = pair[side].decode()
        for k, (where, bad) in enumerate(VALUES):
            yield side, f"value {where}={bad!r}", _break_value(text, where, bad, k).encode(), 2
        data = pair[side]
        for cut in rng.integers(100, len(data), 2):
            yield side, f"truncated at {cut}", data[:cut], None
        for pos in rng.integers(0, len(data), 4):
            b = bytearray(data)
            b[pos] ^= 1 << int(rng.integers(8))
            yield side, f"bit flip at {pos}", bytes(b), None
    for side in ("sut.mseed", "ref.mseed"):
        data = pair[side]
        for cut in rng.integers(1, len(data), 2):
            yield side, f"truncated at {cut}", data[:cut], None
        for j in range(4):
            pos = int(rng.integers(0, 64) if j % 2 == 0 else rng.integers(0, len(data)))
            b = bytearray(data)
            b[pos] ^= 1 << int(rng.integers(8))
            yield side, f"bit flip at {pos}", bytes(b), None


def _run(folder, pair, side, blob, capfd):
    for name in FILES:
        (folder / name).write_bytes(blob if name == side else pair[name])
    out = folder / "out"
    capfd.readouterr()
    try:
        code = main(["fit", "--ref", str(folder / "ref.mseed"), "--ref-xml",
                     str(folder / "ref.xml"), "--sut", str(folder / "sut.mseed"), "--sut-xml",
                     str(folder / "sut.xml"), "--out", str(out), *FIT])
    except BaseException as exc:      # noqa: BLE001 - any escape is the failure looked for
        pytest.fail(f"{side}: {type(exc).__name__} escaped: {exc}")
    return code, capfd.readouterr().err, out


def test_corrupted_inputs_end_cleanly(pair, tmp_path, capfd):
    seen = {0: 0, 2: 0}
    for i, (side, what, blob, want) in enumerate(_cases(pair)):
        folder = tmp_path / f"case{i}"
        folder.mkdir()
        code, err, out = _run(folder, pair, side, blob, capfd)
        case = f"{side} {what}: exit {code}, stderr {err!r}"
        assert code in (0, 2), case
        assert "Traceback" not in err, case
        assert not [p for p in folder.iterdir() if p.name.startswith(".out")], case
        if want is not None:
            assert code == want, case
        if code == 2:
            lines = err.strip().splitlines()
            errors = [ln for ln in lines if not ln.startswith("bayescal: warning:")]
            assert len(errors) == 1 and errors[0].startswith("bayescal: error: "), case
            assert not out.exists(), case
            if want == 2:      # a malformed value: the file and the channel are named
                assert f"{folder / side}: channel XX.SIM." in errors[0], case
        else:
            assert json.loads((out / "result.json").read_text())["schema"] == "bayescal.fit/1"
            for name in ("samples.npz", "diagnostics.npz", "sut_corrected.xml"):
                assert (out / name).stat().st_size > 0, case
        seen[code] += 1
    assert seen[2] >= 2 * len(VALUES) and seen[0] >= 3, seen


def test_noise_refuses_a_malformed_sensitivity(tmp_path, capfd):
    from bayescal.simulate.selfnoise import simulate_colocated

    data, xml = simulate_colocated(1200.0, 10.0, seed=3).write(str(tmp_path))
    text = open(xml[1]).read()
    open(xml[1], "w").write(_break_value(text, r"InstrumentSensitivity>\s*<Value", "abc", 0))
    out = tmp_path / "noise"
    capfd.readouterr()
    assert main(["noise", "--data", *data, "--xml", *xml, "--out", str(out), "--quiet"]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"bayescal: error: {xml[1]}: channel XS.SIM.10.BHZ"), err
    assert "sensitivity value 'abc' is not a number" in err[0]
    assert not out.exists()
