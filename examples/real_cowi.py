"""Real-data validation 1: the ASL COWI azimuth set. The horizontals of
US.COWI (sensor under test) against XX.AZI8.10 LH1/LH2 (reference; gaps, no
vertical), band 1/8 to 1/3 Hz, 2010-08-24T02:00 to 13:00 (day 236), as in
the ASL Sensor Test Suite's own test, which expects COWI rotated 3.2 degrees
clockwise from AZI8 (tolerance 0.5 degree).

Neither sensor comes with StationXML; both are flat broadbands in this band,
so the run uses ``--ref-xml flat --sut-xml flat``: a flat velocity response
and nominal orientations from the channel codes (LH1 = 0, LH2 = 90,
LHN = 0, LHE = 90, LHZ vertical). The SUT azimuths are therefore relative to
AZI8's LH1 taken as north.

    python examples/real_cowi.py [--data DIR] [--out reports/cowi]
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from _real import parse_args, run_bayescal

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
PUBLISHED_DEG, PUBLISHED_TOL = 3.2, 0.5


def command(data, out, seed=0):
    """The ``bayescal fit`` arguments of this validation."""
    return ["fit", "--ref", str(data / "DT000110.LH1"), str(data / "DT000110.LH2"),
            "--ref-xml", "flat", "--sut", str(data / "C100823215422_COWI.LHx"),
            "--sut-xml", "flat", "--out", out, "--band", "0.125", "0.3333333",
            "--start", "2010-08-24T02:00:00", "--end", "2010-08-24T13:00:00",
            "--seed", str(seed), "--quiet", "--no-report"]


def rotation(channels):
    """Per horizontal channel, its azimuth minus its nominal azimuth."""
    out = {}
    for cid, e in channels.items():
        nominal = e["nominal"]["azimuth_deg"]
        a = e["azimuth_deg"]
        out[cid] = {k: (a[k] - nominal if k == "median" else [v - nominal for v in a[k]])
                    for k in ("median", "ci68", "ci95")}
    return out


def main(argv=None):
    a = parse_args(__doc__, DEFAULT_DATA, ROOT / "reports" / "cowi", argv)

    cmd = command(a.data, a.out, a.seed)
    elapsed = run_bayescal(cmd)
    res = json.load(open(os.path.join(a.out, "result.json")))
    print(f"fitted in {elapsed:.1f} s; data used: {res['meta']['data_used']['segments']} segments")
    for cid, r in rotation(res["channels"]).items():
        ok = abs(r["median"] - PUBLISHED_DEG) <= PUBLISHED_TOL
        print(f"  {cid}: rotated {r['median']:+.2f} deg clockwise, 95 % "
              f"[{r['ci95'][0]:+.2f}, {r['ci95'][1]:+.2f}]  (ASL: {PUBLISHED_DEG} +- "
              f"{PUBLISHED_TOL}: {'agrees' if ok else 'DISAGREES'})")
    for cid, why in res["not_estimable"].items():
        print(f"  {cid}: not estimable ({why})")
    c = res["convergence"]
    print(f"  convergence: ESS min {c['ess_min']:.0f}, R-hat max {c['rhat_max']:.4f}")


if __name__ == "__main__":
    main()
