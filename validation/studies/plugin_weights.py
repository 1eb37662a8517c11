"""The plug-in noise model's band weights (``bayescal/core/model/plugin.py``),
before and after, on the same seeds.

Each cell fits the same seeded pairs of ``validation/studies/eiv_coverage.py`` (10
Hz, band 0.02-1 Hz, gains 3 % off their metadata and fitted, self-noise
white in counts) by MCMC as ``bayescal fit`` does, with the weights and with
them switched off, and reports per parameter kind the z sd and the count
inside the 90 % intervals, plus the range of the weights the fits used.

    python validation/studies/plugin_weights.py --out validation/results/eiv/plugin_weights.json     # about 4 min

Cells: record 900 s and 3600 s; ``quiet`` with a noise-free reference and
``estimate`` at reference/SUT noise ratios 0, 1 and 10; pairs at coherence
0.9 (seeds 1000-1023) and 0.99 (1100-1123).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import eiv_coverage as ec                      # the sibling study, run as a script

from bayescal.core.model import plugin

CELLS = [(mode, ratio, duration) for duration in (900.0, 3600.0)
         for mode, ratio in (("quiet", 0.0), ("estimate", 0.0), ("estimate", 1.0),
                             ("estimate", 10.0))]
COHERENCES = {0.9: 1000, 0.99: 1100}


def run_cell(mode, ratio, duration, n, weighted):
    orig = plugin.band_weights
    if not weighted:
        plugin.band_weights = lambda *args: None
    weights = []

    def keep(post):
        w = post.meta.plugin_weights
        if w:
            weights.extend(w)
    calibrate = ec.calibrate

    def calibrate_and_keep(*a, **k):
        post = calibrate(*a, **k)
        keep(post)
        return post
    ec.calibrate = calibrate_and_keep
    try:
        rows = [ec.run_pair(seed, ratio, coh, "gain", mode, duration=duration)
                for coh, first in COHERENCES.items() for seed in range(first, first + n)]
    finally:
        plugin.band_weights, ec.calibrate = orig, calibrate
    return rows, weights


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=24, help="pairs per coherence")
    ap.add_argument("--out", default="validation/results/eiv/plugin_weights.json")
    args = ap.parse_args(argv)
    out, t0 = [], time.time()
    for mode, ratio, duration in CELLS:
        cell = {"mode": mode, "ratio": ratio, "duration_s": duration}
        for weighted in (False, True):
            rows, w = run_cell(mode, ratio, duration, args.n, weighted)
            summ = {s["kind"]: s for s in ec.summarise(rows)}
            cell["weighted" if weighted else "unweighted"] = {
                "summary": summ, "weights_range": [min(w), max(w)] if w else None,
                "worst": sorted(({"seed": r["seed"], "check": k, "z": c["z"]} for r in rows
                                 for k, c in r["checks"].items()),
                                key=lambda d: -abs(d["z"]))[:3]}
        out.append(cell)
        def fmt(kind):
            u, w = (cell[k]["summary"][kind] for k in ("unweighted", "weighted"))
            return (f"{kind} {u['z_sd']:.2f}->{w['z_sd']:.2f} "
                    f"({u['in90']}->{w['in90']}/{w['n']} {w['band90']})")
        wr = cell["weighted"]["weights_range"]
        print(f"{duration:.0f} s {mode} ratio {ratio:g}: "
              + ", ".join(fmt(k) for k in ("azimuth", "dip", "gain"))
              + (f"; weights {wr[0]:.2f}-{wr[1]:.2f}" if wr else "")
              + f" ({time.time() - t0:.0f} s)", flush=True)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"command": "python validation/studies/plugin_weights.py " + " ".join(argv or sys.argv[1:]),
                   "n_per_coherence": args.n, "coherences": COHERENCES, "cells": out,
                   "seconds": time.time() - t0}, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
