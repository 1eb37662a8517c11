"""Two facts of a random run's band variance (``bayescal/coil/bandvariance.py``):
its cost, and how far the README run's lowest band is from the band-mean
formula.

* Cost: CPU seconds of :class:`~bayescal.coil.bandvariance.BandVariance`
  (the kernels from the recorded input) on an hour and on 4 hours at 5 Hz
  (fit lp) and on 10 minutes at 100 Hz (fit hf), the median of 3.
* The README's run (``simulate_random_cal(truth=(121, 0.72, 1510),
  duration=3600, fs=5, seed=1)``), per band: ``n_bins sum_f S_NN S_AA /
  (sum_f S_NN sum_f S_AA)``, the variance of the band residual over what
  the band mean of the residual's power gives, with ``S_AA`` the recorded
  input's power per bin and ``S_NN`` the simulator's noise in ground
  velocity (white acceleration, rms 5 % of the coil signal's, plus the
  digitizer's white count noise through the nominal response), beside the
  closed form for both spectra as ``1/f^2`` on the bins 2-9 of a segment,
  ``8 sum k^-4 / (sum k^-2)^2``.

    python validation/studies/cal_band_variance.py
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_results  # noqa: E402
from cal_readme import COIL, DIGITIZER_NOISE, SELF_NOISE, TRUTH  # noqa: E402

from bayescal import coil  # noqa: E402
from bayescal.coil.bandvariance import BandVariance  # noqa: E402
from bayescal.coil.element import run_spectra  # noqa: E402
from bayescal.coil.random import default_cal_band  # noqa: E402
from bayescal.simulate.cal import HF_NOMINAL, simulate_random_cal  # noqa: E402

#: (name, duration s, fs Hz, fit) of the timed runs.
CASES = (("1 h at 5 Hz", 3600.0, 5.0, "lp"), ("4 h at 5 Hz", 4 * 3600.0, 5.0, "lp"),
         ("10 min at 100 Hz", 600.0, 100.0, "hf"))


def read(sim):
    return coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")


def cost(duration, fs, fit, repeats=3):
    """Median CPU seconds of the band variance of one run, and its bands."""
    hf = dict(hf_true=HF_NOMINAL, hf_nominal=HF_NOMINAL) if fit == "hf" else {}
    run = read(simulate_random_cal(duration=duration, fs=fs, seed=1, **hf))
    band = default_cal_band(run, fit)
    sp = run_spectra(run, COIL, band)
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        BandVariance(run, COIL, sp, band)
        times.append(time.process_time() - t0)
    return {"cpu_s": float(np.median(times)), "bands": int(sp.n_bands)}


def band_mean_ratio():
    """Per band of the README run: the variance ratio (module docstring)."""
    run = read(simulate_random_cal(truth=TRUTH, duration=3600, fs=5, seed=1))
    band = default_cal_band(run, "lp")
    sp = run_spectra(run, COIL, band)
    f = sp.freqs
    saa = sp.total[:, 1, 1].real
    h = np.abs(run.nominal_response(f)[0])
    snn = (SELF_NOISE / (2 * np.pi * f)) ** 2 + (DIGITIZER_NOISE / h) ** 2
    ratios, bins = [], []
    for b in range(sp.n_bands):
        m = sp.band_of == b
        ratios.append(float(m.sum() * (snn[m] * saa[m]).sum() / (snn[m].sum() * saa[m].sum())))
        bins.append(int(m.sum()))
    k = np.arange(2, 10.0)
    return {"ratio": ratios, "bins": bins, "band_hz": [float(f[sp.band_of == 0].min()),
                                                       float(f[sp.band_of == 0].max())],
            "closed_form_bins_2_9": float(8 * (k ** -4).sum() / (k ** -2).sum() ** 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation/results/cal/band_variance.json")
    args = ap.parse_args()
    out = {"command": "python validation/studies/cal_band_variance.py",
           "cost": {name: cost(d, fs, fit) for name, d, fs, fit in CASES},
           "readme_run": band_mean_ratio()}
    study_results.write(args.out, out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
