"""Regenerate the gallery of example calibration reports in ``reports/``
(``make reports``).

Cases (each written to ``reports/<name>/``: ``result.json``, ``samples.npz``,
``diagnostics.npz``, ``truth.json`` for simulations, ``report.pdf`` and
``report_*.png``):

* ``simulated``: orientation only; BH1 turned 7 deg from its nominal north
  (flagged at the 5 deg tolerance), BH2 2.5 deg, BHZ tilted 0.6 deg.
* ``simulated_response``: period, damping and gain of every channel fitted
  (``fit_response="all"``), the true responses differing from the nominal
  StationXML by a few per cent.
* ``huddle``: ObsPy's huddle pair (real data, vertical only, response fitted),
  through ``examples/real_huddle.py``; skipped when ``../shared/data`` is
  absent.

    python examples/make_reports.py [--out reports] [--only simulated ...]
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"


def _simulated_fit(folder, sim_kw, fit_kw):
    """Simulate a pair, fit it, save result and truth into ``folder``."""
    import bayescal
    from bayescal.simulate import simulate_pair

    sim = simulate_pair(**sim_kw)
    post = bayescal.calibrate(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory,
                              progress=False, **fit_kw)
    post.save(folder)
    with open(os.path.join(folder, "truth.json"), "w") as fh:
        json.dump(sim.truth, fh, indent=2)
    return folder


def simulated(out):
    """Orientation-only fit of a simulated pair with one channel off tolerance."""
    return _simulated_fit(os.path.join(out, "simulated"),
                          dict(duration=7200, fs=20, seed=1, coherence=0.99,
                               sut_azimuth=(7.0, 92.5, 0.0), sut_dip=(0.0, 0.3, -89.4)),
                          dict(band=(0.03, 1.0), seed=1))


def simulated_response(out):
    """Fit of orientation and full response (period, damping, gain)."""
    return _simulated_fit(os.path.join(out, "simulated_response"),
                          dict(duration=3600, fs=10, seed=5, coherence=0.99,
                               sut_azimuth=(2.0, 91.0, 0.0),
                               sut_response=((28.0, 0.68, 780.0), (31.0, 0.72, 730.0),
                                             (30.0, 0.70, 760.0)),
                               nominal_response=(30.0, 0.707, 750.0)),
                          dict(band=(0.03, 1.0), fit_response="all", seed=5))


def huddle(out):
    """ObsPy huddle pair through examples/real_huddle.py (None without data)."""
    if not DATA.is_dir():
        print(f"huddle: skipped, {DATA} not found")
        return None
    spec = importlib.util.spec_from_file_location("real_huddle", ROOT / "examples" / "real_huddle.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    dest = os.path.join(out, "huddle")
    try:
        mod.main(["--data", str(DATA), "--out", dest])
    except SystemExit as exc:
        if exc.code:
            print(f"huddle: real_huddle.py failed ({exc.code})")
            return None
    return os.path.join(dest, "fit")


CASES = {"simulated": simulated, "simulated_response": simulated_response, "huddle": huddle}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "reports"))
    p.add_argument("--only", nargs="*", choices=sorted(CASES), default=list(CASES))
    p.add_argument("--threshold", type=float, default=5.0, help="flag tolerance (deg)")
    a = p.parse_args(argv)
    from bayescal.report import write_report

    for name in a.only:
        t0 = time.perf_counter()
        folder = CASES[name](a.out)
        if folder is None:
            continue
        t1 = time.perf_counter()
        paths = write_report(folder, nominal_tolerance_deg=a.threshold)
        t2 = time.perf_counter()
        size = sum(os.path.getsize(q) for q in paths) / 1e6
        print(f"{name}: fit {t1 - t0:.1f} s, report {t2 - t1:.1f} s -> {paths[0]}"
              f" (+{len(paths) - 1} PNG, {size:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
