"""ObsPy's huddle pair (an STS-2 and an unknown sensor, vertical): the SUT's
response relative to the reference's metadata under the headline model
(result.json's ``response_curve``) against ObsPy's ``rel_calib_stack``
result (``unknown.resp``, which is conj(H_sut / H_ref) * H_ref with H_ref
the STS-2's simplified response, ``STS2_simp.cal``): amplitude ratio and
phase difference of conj(R_fit) * H_STS2simp against the table at 30
log-spaced frequencies in 0.15-10 Hz (issue 40's proof: median
|ratio - 1| <= 2 %, max 5 %; median |phase difference| <= 0.03 rad, max
0.05). Needs the shared data (../shared/data/real/obspy_relcal); about a
minute per fit.

    python validation/studies/huddle_relative_response.py [--sut-xml flat] [--band 0.15 10]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"


def compare(curve, cal, table, freqs):
    """(amplitude ratio - 1, phase difference in rad) of conj(R) * H_cal
    against ``table`` (frequency, amplitude, phase rows of ``unknown.resp``)
    at ``freqs``: R interpolated in log frequency from ``curve`` (one
    channel's ``response_curve`` entry and its grid ``curve_f``)."""
    entry, grid = curve
    x = np.log(freqs)
    amp = np.interp(x, np.log(grid), entry["amplitude"]["median"])
    ph = np.interp(x, np.log(grid), entry["phase_rad"]["median"])
    ours = np.conj(amp * np.exp(1j * ph)) * cal
    f, a, p = table.T
    theirs = np.interp(x, np.log(f), a) * np.exp(1j * np.interp(x, np.log(f), p))
    ratio = ours / theirs
    return np.abs(ratio) - 1.0, np.angle(ratio)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--sut-xml", default="flat")
    ap.add_argument("--band", nargs=2, type=float, default=None)
    a = ap.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    from bayescal.cli import main as cli
    from bayescal.io import read_gse2_paz
    from bayescal.core.response import transfer

    d = a.data
    out = Path(tempfile.mkdtemp()) / "huddle"
    cli(["fit", "--ref", str(d / "ref_STS2"), "--ref-xml", str(d / "STS2_simp.cal"),
         "--sut", str(d / "ref_unknown"), "--sut-xml", a.sut_xml, "--out", str(out),
         "--no-report", "--quiet", *(["--band", *map(str, a.band)] if a.band else [])])
    result = json.loads((out / "result.json").read_text())
    curve = result["response_curve"]
    (entry,) = curve["channels"].values()
    poles, zeros, gain = read_gse2_paz(str(d / "STS2_simp.cal"))
    freqs = np.geomspace(0.15, 10.0, 30)
    lo, hi = curve["freq_hz"][0], curve["freq_hz"][-1]
    freqs = freqs[(freqs >= lo) & (freqs <= hi)]
    cal = gain * transfer(2j * np.pi * freqs, zeros, poles)
    amp, phase = compare((entry, np.asarray(curve["freq_hz"])), cal,
                         np.loadtxt(d / "unknown.resp"), freqs)
    print(f"headline: {result['meta']['headline']['model']}, effects {curve['effects']}, "
          f"left out {curve['left_out']}; band {lo:.3g}-{hi:.3g} Hz, {freqs.size} frequencies")
    print(f"amplitude |ratio - 1|: median {np.median(np.abs(amp)):.4f}, max "
          f"{np.max(np.abs(amp)):.4f}")
    print(f"phase |difference| (rad): median {np.median(np.abs(phase)):.4f}, max "
          f"{np.max(np.abs(phase)):.4f}")


if __name__ == "__main__":
    main()
