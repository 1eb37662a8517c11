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
  through ``examples/real_huddle.py``; ``cowi``: the ASL COWI azimuth set
  through ``examples/real_cowi.py``; both skipped when ``../shared/data`` is
  absent.
* ``uvw`` and ``batch``: the other issues' galleries, through
  ``examples/uvw_example.py`` and ``examples/batch_example.py`` (they write
  their own reports).
* ``xpfo_noise``: ``bayescal noise`` on the three II.XPFO verticals through
  ``examples/real_xpfo.py`` (noise.json, noise.pdf, noise_Z.png; skipped
  when ``../shared/data`` is absent).

    python examples/make_reports.py [--out reports] [--only simulated ...]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _simulated_fit(folder, sim_kw, fit_kw):
    """Simulate a pair, fit it, save result and truth into ``folder``."""
    import bayescal
    from bayescal.io.result import save_posterior
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(**sim_kw)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              progress=False, **fit_kw)
    save_posterior(post, folder)
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


def _script(name, script, needs_data=None):
    """A case run by another example script (``examples/<script>``) with
    ``--out reports/<name>``; a calibration report is rendered for the
    result folder it leaves (``<name>/`` or ``<name>/fit/``), if any. Cases
    on real data are skipped when ``../shared/data`` is absent."""
    def run(out):
        dest = os.path.join(out, name)
        if needs_data is not None and not needs_data.is_dir():
            print(f"{name}: skipped, {needs_data} not found")
            return None
        rc = subprocess.run([sys.executable, str(ROOT / "examples" / script), "--out", dest],
                            cwd=ROOT).returncode
        if rc:
            print(f"{name}: examples/{script} failed (exit code {rc})")
            return None
        for folder in (dest, os.path.join(dest, "fit")):
            if os.path.exists(os.path.join(folder, "samples.npz")):
                return folder
        return None                      # the script wrote its own report
    run.__doc__ = f"examples/{script} into reports/{name}/"
    return run


REAL = ROOT.parent / "shared" / "data" / "real"
CASES = {"simulated": simulated, "simulated_response": simulated_response,
         "huddle": _script("huddle", "real_huddle.py", REAL / "obspy_relcal"),
         "cowi": _script("cowi", "real_cowi.py", REAL / "asl_cowi_azimuth"),
         "xpfo_noise": _script("xpfo_noise", "real_xpfo.py", REAL / "xpfo_selfnoise"),
         "uvw": _script("uvw", "uvw_example.py"),
         "batch": _script("batch", "batch_example.py")}


def main(argv=None):
    p = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    p.add_argument("--out", default=str(ROOT / "reports"))
    p.add_argument("--only", nargs="*", choices=sorted(CASES), default=list(CASES))
    p.add_argument("--threshold", type=float, default=5.0, help="flag tolerance (deg)")
    a = p.parse_args(argv)
    from bayescal.report.fit import write_report

    for name in a.only:
        t0 = time.perf_counter()
        folder = CASES[name](a.out)
        if folder is None:
            continue
        t1 = time.perf_counter()
        paths = write_report(folder, nominal_tolerance_deg=a.threshold, png=True, full=True)
        t2 = time.perf_counter()
        size = sum(os.path.getsize(q) for q in paths) / 1e6
        print(f"{name}: fit {t1 - t0:.1f} s, report {t2 - t1:.1f} s -> {paths[0]}"
              f" (+{len(paths) - 1} PNG, {size:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
