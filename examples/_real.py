"""What the real-data examples share: their command line and one timed
`bayescal` run."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def parse_args(doc, default_data, default_out, argv=None):
    """``--data``, ``--out``, ``--seed``; exits with a message when the data
    folder is absent."""
    p = argparse.ArgumentParser(description=" ".join(doc.split("\n\n")[0].split()))
    p.add_argument("--data", type=Path, default=default_data)
    p.add_argument("--out", default=str(default_out))
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    return a


def run_bayescal(cmd):
    """Print and run ``bayescal cmd``; exits on failure, returns the seconds taken."""
    from bayescal.cli import main as cli

    print("bayescal " + " ".join(cmd))
    t0 = time.perf_counter()
    rc = cli(cmd)
    if rc:
        sys.exit(rc)
    return time.perf_counter() - t0
