"""Running ``bayescal fit`` as a user runs it (a subprocess), and the checks
every bad-input case shares. Used by the command-line tests and by the one
fit run they share (``cli_fit`` in conftest.py)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.tolerance import Z_001, median_mc_error  # noqa: F401  (re-exported)

PY = sys.executable


def run_fit(*args, out):
    """``bayescal fit ARGS --out OUT --quiet --no-report`` in a subprocess."""
    cmd = [PY, "-m", "bayescal.cli", "fit", *map(str, args), "--out", str(out), "--quiet",
           "--no-report"]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def base_args(f, **over):
    """The four input options of the simulated pair's files ``f``; ``over``
    replaces any of them."""
    a = {"--ref": f["ref.mseed"], "--ref-xml": f["ref.xml"], "--sut": f["sut.mseed"],
         "--sut-xml": f["sut.xml"]}
    a.update(over)
    return [x for k, v in a.items() for x in (k, v)]


def read_result(out):
    return json.loads((Path(out) / "result.json").read_text())


def assert_user_error(proc, out, name, what):
    """Exit code 2, one ``bayescal: error:`` line naming ``name`` and saying
    ``what``, no traceback, nothing written."""
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.strip().splitlines() if not ln.startswith("bayescal: warn")]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("bayescal: error:")
    assert "Traceback" not in proc.stderr
    assert name in lines[0], lines[0]
    assert what in lines[0], lines[0]
    assert not Path(out).exists()
    assert not [p for p in Path(out).parent.iterdir() if ".tmp-" in p.name]
