"""Start-up: each command pays for the imports it uses, when it uses them."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _loaded(code):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=str(ROOT), check=True).stdout.strip()
    return eval(out)                                   # noqa: S307 - our own printout


def test_help_loads_no_scipy():
    """``bayescal --help`` builds every sub-command's options and loads no
    scipy, emcee, ObsPy or matplotlib (scipy.special alone is about 0.15 s
    of a command's start-up)."""
    loaded = _loaded("import sys; from bayescal.cli import build_parser; build_parser(); "
                     "print(sorted({m.split('.')[0] for m in sys.modules} & "
                     "{'scipy', 'emcee', 'obspy', 'matplotlib'}))")
    assert loaded == []
