"""Same cross-spectra from two source trees: the pair fit's spectra, compared.

Two pairs: ``benchmarks/bench_process.py``'s 2-hour 20-Hz 3+3 simulated pair
(its ``DEMO_TRUTH``, band chosen from the data, transients left out as a fit
does) and ObsPy's huddle pair (``../shared/data/real/obspy_relcal``, band
0.1-2 Hz; skipped without it). Each tree prepares each pair in a fresh
subprocess (``bayescal.pair.preparation.prepare``, the fit's first step);
its spectra are compared array by array: the segment-summed matrices
(``total``), the per-segment band matrices (``per_segment``) and the time
blocks (``block_totals``, single precision). A difference is stated
relative to the channels' powers, ``|a_ij - b_ij| / sqrt(a_ii a_jj)`` at
the same frequency (or band, or block), largest over all elements; the band
and the segments used must be the same.

    python validation/studies/same_spectra.py --before /work/main
        [--out validation/results/speed/same_spectra.json]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import study_results                          # the sibling module, run as a script

ROOT = Path(__file__).resolve().parents[2]
HUDDLE = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"

PREPARE = """
import sys, warnings
import numpy as np
import obspy
warnings.simplefilter("ignore")
from bayescal.pair.preparation import prepare
ref, ref_xml, sut, sut_xml, out = sys.argv[1:6]
band = tuple(map(float, sys.argv[6:8])) if len(sys.argv) > 6 else None
sp = prepare(ref=obspy.read(ref), ref_xml=ref_xml, sut=obspy.read(sut), sut_xml=sut_xml,
             band=band).spectra
np.savez(out, total=sp.total, per_segment=sp.per_segment, block_totals=sp.block_totals,
         band=sp.band_edges[[0, -1]], starts=sp.segment_starts)
"""


def _prepare(tree, args, out):
    """The spectra arrays of the pair ``args`` (four files, then the band
    or nothing) prepared by the source tree ``tree``, by way of ``out``."""
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", PREPARE, *args[:4], out, *args[4:]], env=env,
                   check=True, cwd=os.path.dirname(out))
    return dict(np.load(out))


def relative(a, b):
    """Largest ``|a_ij - b_ij| / sqrt(a_ii a_jj)`` over ``a`` (..., n, n)."""
    a, b = np.asarray(a, complex), np.asarray(b, complex)
    power = np.real(np.einsum("...ii->...i", a))
    scale = np.sqrt(np.abs(power[..., :, None] * power[..., None, :]))
    return float(np.max(np.abs(a - b) / scale))


def compare(a, b):
    """The differences the module docstring lists, ``a`` the reference tree's."""
    same = bool(np.array_equal(a["band"], b["band"]) and np.array_equal(a["starts"], b["starts"]))
    return {"same_band_and_segments": same, "band_hz": a["band"].tolist(),
            "segments": int(a["starts"].size),
            **({f"{k}_max_rel": relative(a[k], b[k])
                for k in ("total", "per_segment", "block_totals")} if same else {})}


def _pairs(tmp):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    sys.path.insert(0, str(ROOT))
    from bench_process import DEMO_TRUTH

    from bayescal.simulate.pair import simulate_pair
    p = simulate_pair(**DEMO_TRUTH).write(os.path.join(tmp, "sim"))
    pairs = {"demo_2h_20Hz": [p["ref.mseed"], p["ref.xml"], p["sut.mseed"], p["sut.xml"]]}
    if HUDDLE.is_dir():
        sys.path.insert(0, str(ROOT / "examples"))
        from real_huddle import write_inputs

        ref_xml, sut_xml = write_inputs(HUDDLE, os.path.join(tmp, "huddle"))
        pairs["huddle"] = [str(HUDDLE / "ref_STS2"), ref_xml, str(HUDDLE / "ref_unknown"),
                           sut_xml, "0.1", "2"]
    return pairs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the other source tree")
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "speed"
                                         / "same_spectra.json"))
    a = ap.parse_args(argv)
    result = {"command": "python validation/studies/same_spectra.py "
                         + " ".join(argv or sys.argv[1:])}
    with tempfile.TemporaryDirectory() as tmp:
        for name, args in _pairs(tmp).items():
            before = _prepare(a.before, args, os.path.join(tmp, name + "_before.npz"))
            after = _prepare(ROOT, args, os.path.join(tmp, name + "_after.npz"))
            result[name] = compare(before, after)
    study_results.write(a.out, result)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
