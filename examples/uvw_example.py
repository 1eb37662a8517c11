"""Worked example: coil-by-coil (UVW) calibration of a simulated STS-2.

1. Simulate three calibration runs (U, V, W coils driven one at a time with a
   pseudo-random binary sequence) of an STS-2-like sensor whose elements
   differ from the nominal by a few per cent, and write them as miniSEED plus
   the SUT StationXML into ``OUT/input/``.
2. Run ``bayescal uvw`` on those files: posterior per element, XYZ responses,
   cross-talk, Z-only check, report pages in ``OUT/``.
3. Compare with the truth, and rotate one run's XYZ outputs to UVW (the
   everyday use: find a noisy or dead element in ordinary recordings).

    .venv/bin/python examples/uvw_example.py --out reports/uvw
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from obspy import read

from bayescal import cli, coil
from bayescal.simulate.coil import simulate_calibration

ELEMENTS = ((118.0, 0.700, 1490.0),   # U: period (s), damping, gain (V per m/s)
            (121.5, 0.720, 1512.0),   # V
            (119.0, 0.690, 1500.0))   # W
COIL_CONSTANT = 1e-9                  # m/s^2 per input count


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="reports/uvw")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    sim = simulate_calibration(elements=ELEMENTS, seed=args.seed, duration=8 * 3600.0,
                               coil_constant=COIL_CONSTANT)
    paths = sim.write(os.path.join(args.out, "input"))
    argv = ["uvw", "--cal", f"U={paths['U']}", "--cal", f"V={paths['V']}",
            "--cal", f"W={paths['W']}", "--input-channel", "BC0",
            "--coil-constant", str(COIL_CONSTANT), "--sensor", "sts2",
            "--sut-xml", paths["xml"], "--out", args.out, "--seed", str(args.seed)]
    print("bayescal " + " ".join(argv))
    t0 = time.perf_counter()
    rc = cli.main(argv)
    print(f"exit code {rc}, {time.perf_counter() - t0:.0f} s")
    if rc:
        return rc

    with open(os.path.join(args.out, "uvw.json")) as fh:
        summary = json.load(fh)
    print("\nelement   parameter   truth      median     95 % interval        error")
    for e, truth in zip(coil.ELEMENTS, ELEMENTS):
        for p, t in zip(coil.PARAMS, truth):
            s = summary["elements"][e][p]
            print(f"{e:8s}  {p:10s}  {t:9.4f}  {s['median']:9.4f}  "
                  f"[{s['ci95'][0]:9.4f}, {s['ci95'][1]:9.4f}]  {100 * (s['median'] / t - 1):+.3f} %")

    # everyday use: rotate recorded XYZ to UVW. In the V run only V is driven,
    # so V carries the signal and U, W only their self-noise.
    st = read(paths["V"]).select(channel="LH?")
    rot = coil.xyz_to_uvw(st, coil.STS2_UVW, source=paths["V"])
    print("\nV run rotated to UVW, rms (counts):",
          ", ".join(f"{tr.stats.channel}: {np.std(tr.data):.3g}" for tr in rot))
    print(f"\nreport: {os.path.join(args.out, 'uvw_report.pdf')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
