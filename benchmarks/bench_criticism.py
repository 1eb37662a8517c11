"""What the criticism adds to ``bayescal fit`` on the real examples and the
demo: the fit with ``diagnose=False`` against the same fit with the
criticism (the default), wall-clock seconds, median of ``--repeats`` runs in
one process, the same run order for both. The target: the criticism adds at
most max(15 s, the fit's own time).

    python benchmarks/bench_criticism.py --out reports/benchmarks/criticism.json

Needs ../shared/data/real (COWI and the huddle pair); the demo's recordings
are simulated here (examples/demo.py's pair).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "real"
sys.path.insert(0, str(ROOT / "examples"))


def cases(folder):
    from demo import TRUTH_RESPONSE
    from real_huddle import write_inputs

    from bayescal.simulate.pair import simulate_pair
    c = DATA / "asl_cowi_azimuth"
    h = DATA / "obspy_relcal"
    ref_xml, sut_xml = write_inputs(h, os.path.join(folder, "huddle"))
    demo = simulate_pair(duration=7200, fs=20, seed=2026, coherence=0.995,
                         sut_azimuth=(3.0, 93.4, 25.0), sut_dip=(0.0, 0.3, -89.6),
                         sut_response=TRUTH_RESPONSE, nominal_response=(30.0, 0.707, 750.0)
                         ).write(os.path.join(folder, "demo"))
    return {
        "cowi": dict(ref=[str(c / "DT000110.LH1"), str(c / "DT000110.LH2")], ref_xml="flat",
                     sut=[str(c / "C100823215422_COWI.LHx")], sut_xml="flat",
                     band=(0.125, 1 / 3.0), start="2010-08-24T02:00:00",
                     end="2010-08-24T13:00:00"),
        "huddle (band from the data)": dict(ref=str(h / "ref_STS2"), ref_xml=ref_xml,
                                            sut=str(h / "ref_unknown"), sut_xml=sut_xml),
        "demo (gains only)": dict(ref=demo["ref.mseed"], ref_xml=demo["ref.xml"],
                                  sut=demo["sut.mseed"], sut_xml=demo["sut.xml"],
                                  band=(0.01, 1.0), seed=2026),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="reports/benchmarks/criticism.json")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        sys.exit(f"{DATA} not found (see ../shared/data/README.md)")
    from bayescal.pair.workflow import calibrate_files
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, kw in cases(tmp).items():
            fit, full, verdict, named = [], [], None, []
            for _ in range(args.repeats):
                for diagnose, store in ((False, fit), (True, full)):
                    t0 = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        post = calibrate_files(progress=False, diagnose=diagnose, **kw)
                    store.append(time.perf_counter() - t0)
                    if diagnose:
                        verdict = post.criticism.get("verdict")
                        named = [e["name"] for e in post.criticism.get("effects", [])]
            f, a = float(np.median(fit)), float(np.median(full))
            out[name] = {"fit_s": f, "fit_with_criticism_s": a, "added_s": a - f,
                         "limit_s": max(15.0, f), "within": a - f <= max(15.0, f),
                         "verdict": verdict, "named": named, "repeats": args.repeats}
            print(f"{name:28s} fit {f:5.1f} s, with criticism {a:5.1f} s (+{a - f:.1f} s; "
                  f"limit {max(15.0, f):.0f} s) verdict {verdict}, named {named}", flush=True)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"cases": out, "note": "wall-clock medians in one process, 2-core machine "
                   "shared with other work"}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
