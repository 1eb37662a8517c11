"""The record a short-record fit uses: seconds and periods of the band's
lower edge (``meta["record_length"]``, :mod:`bayescal.core.checks.record_length`)
for the table rows of docs/validation/errors_in_variables.md, "Short
records".

The same 40 seeded pairs as ``validation/studies/short_records.py`` (seeds
800-839, 10 Hz, coherence 0.9, reference noise-free, self-noise white in
counts), prepared as ``bayescal fit`` prepares them (segments, transient
test, band) without the fit: per row, the seconds used and the periods of
the lower edge they hold (median over the pairs, and the range). A few
seconds a pair.

    python validation/studies/record_periods.py --out validation/results/eiv/record_periods.json
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import study_results                          # the sibling module, run as a script

from bayescal.pair import prepare
from bayescal.simulate import simulate_pair
from bayescal.simulate.harness import NOMINAL, coherences, draw_truth

#: name -> (duration s, band): the short-record table's rows.
ROWS = {"900 s, 0.02-1 Hz": (900.0, (0.02, 1.0)), "1800 s, 0.02-1 Hz": (1800.0, (0.02, 1.0)),
        "3600 s, 0.02-1 Hz": (3600.0, (0.02, 1.0)), "900 s, 0.05-1 Hz": (900.0, (0.05, 1.0))}
SEEDS = range(800, 840)


def record_used(seed, duration, band):
    """``meta["record_length"]`` of pair ``seed`` (short_records.py's draw)."""
    azs, dips, resp = draw_truth(seed, "gain")
    cu, cr = coherences(0.9, 0.0)
    sim = simulate_pair(duration=duration, fs=10.0, seed=seed, coherence=cu, ref_coherence=cr,
                        sut_azimuth=azs, sut_dip=dips, sut_response=resp,
                        nominal_response=NOMINAL, noise_in_counts=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = prepare(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                       sut_xml=sim.sut_inventory, band=band)
    return data.meta["record_length"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation/results/eiv/record_periods.json")
    args = ap.parse_args(argv)
    t0, by_row = time.perf_counter(), {}
    for name, (duration, band) in ROWS.items():
        used = [record_used(s, duration, band) for s in SEEDS]
        sec = [u["seconds"] for u in used]
        per = [u["periods_of_lower_edge"] for u in used]
        by_row[name] = {"seconds_median": float(np.median(sec)), "seconds_range": [min(sec), max(sec)],
                      "periods_median": float(np.median(per)), "periods_range": [min(per), max(per)],
                      "pairs": len(used)}
        print(name, by_row[name], flush=True)
    study_results.write(args.out, {
        "command": "python validation/studies/record_periods.py --out " + args.out,
        "by_row": by_row, "seeds": [SEEDS.start, SEEDS.stop - 1], "seconds": time.perf_counter() - t0})


if __name__ == "__main__":
    main()
