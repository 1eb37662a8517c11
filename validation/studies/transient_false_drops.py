"""How often the transient test drops a segment from a record whose noise is
stationary (the rate it is built for: 1e-3 a record).

Seeded simulated pairs (``bayescal.simulate.simulate_pair``: stationary
Gaussian ground motion and self-noise), their settings drawn per pair: 10
minutes to 2 hours at 1 or 5 Hz, the SUT's coherence 0.9-0.999, the
reference's 0.95, 0.99 or 0.9999, self-noise white in counts or shaped like
the ground, the wavefield's diffuse share 0, 0.3 or 1. Each pair's spectra
(band 0.05 or 0.02 Hz to 0.4 Hz) go through
:func:`bayescal.core.spectra.transients.find`; the records with any segment
dropped are counted.

    python validation/studies/transient_false_drops.py --n 300
"""
from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from bayescal.core.spectra.transients import find
from bayescal.core.spectra.welch import cross_spectra
from bayescal.io.align import align
from bayescal.simulate import simulate_pair

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "transients"
                                         / "false_drops.json"))
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(123)
    records = []
    for i in range(args.n):
        dur = float(rng.choice([600, 1800, 3600, 7200]))
        fs = float(rng.choice([1.0, 5.0]))
        coh = float(rng.uniform(0.9, 0.999))
        ref_coh = float(rng.choice([0.9999, 0.99, 0.95]))
        counts = bool(rng.integers(2))
        diffuse = float(rng.choice([0.0, 0.3, 1.0]))
        p = simulate_pair(duration=dur, fs=fs, seed=1000 + i, coherence=coh,
                          ref_coherence=ref_coh, noise_in_counts=counts, diffuse=diffuse)
        s, r, f, _ = align(p.sut, p.sut_inventory, p.ref, p.ref_inventory)
        band = (0.05 if dur <= 1800 else 0.02, min(0.4, f / 2 * 0.8))
        found = find(cross_spectra(s.data, r.data, f, s.response_fn(), r.response_fn(), band))
        records.append({"seed": 1000 + i, "duration_s": dur, "fs": fs, "coherence": coh,
                        "ref_coherence": ref_coh, "noise_in_counts": counts, "diffuse": diffuse,
                        "segments": int(found.dropped.size), "dropped": found.count,
                        "largest_ratio": float(found.ratio.max())})
    with_drop = sum(r["dropped"] > 0 for r in records)
    out = {"command": "python validation/studies/transient_false_drops.py --n %d" % args.n,
           "records": len(records), "records_with_a_drop": with_drop,
           "segments": int(sum(r["segments"] for r in records)),
           "largest_ratio": max(r["largest_ratio"] for r in records)}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
