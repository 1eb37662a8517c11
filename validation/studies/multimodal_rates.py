"""How often the multimodal flag is raised (docs/validation/multimodal.md).

Seeded simulated pairs, 30 min at 10 Hz, random SUT azimuth:

* ``normal``: six waves and a diffuse field, 3 + 3 channels, gains free,
  coherence 0.9-0.999 (the flag should stay down);
* ``polar:D``: one plane wave with a diffuse field of D times its amplitude,
  a reference with N and E only, gains held (D = 0: each SUT horizontal has
  a mirror mode of comparable height).

The search runs before sampling and does not depend on it, so the sampler
is run short (its intervals are not used here).

    python validation/studies/multimodal_rates.py --n 10 normal polar:0 polar:0.02

prints its table and writes it to ``--out`` (validation/results/multimodal/rates.json).
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair

SHORT = dict(min_ess=50, n_tau=5, max_steps=2000)


def run(kind, seed):
    """(detected, mass fractions of the modes) of one seeded pair."""
    rng = np.random.default_rng(1000 + seed)
    az = float(rng.uniform(0, 360))
    if kind == "normal":
        sim = simulate_pair(duration=1800.0, fs=10.0, seed=seed,
                            coherence=float(rng.uniform(0.9, 0.999)),
                            sut_azimuth=(az, az + 90, 0.0), sut_dip=(0.0, 0.3, -89.6))
        ref, free = sim.ref, "gain"
    else:
        sim = simulate_pair(duration=1800.0, fs=10.0, seed=seed, coherence=0.99, n_waves=1,
                            diffuse=float(kind.split(":")[1]), sut_azimuth=(az, az + 90, 0.0))
        ref, free = sim.ref.select(channel="BH[NE]"), "none"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # the short sampler warns that it did not converge
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=ref, ref_xml=sim.ref_inventory, band=(0.02, 1.0),
                         fit_response=free, progress=False, **SHORT)
    mm = post.summary()["multimodal"]
    return mm["detected"], [m["mass_fraction"] for m in mm["modes"]]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kinds", nargs="+")
    ap.add_argument("--n", type=int, default=10)
    ap.add_argument("--out", default="validation/results/multimodal/rates.json")
    args = ap.parse_args(argv)
    out, t0 = {}, time.time()
    for kind in args.kinds:
        res = [run(kind, s) for s in range(args.n)]
        second = [max(f[1:], default=0.0) for _, f in res]
        out[kind] = {"pairs": args.n, "flagged": int(sum(d for d, _ in res)),
                     "flagged_seeds": [s for s, (d, _) in enumerate(res) if d],
                     "second_mode_mass": second}
        print(f"{kind}: flagged {sum(d for d, _ in res)} / {args.n}; second mode's mass "
              + ", ".join(f"{x:.3g}" for x in second), flush=True)
    study_results.write(args.out, {
        "command": "python validation/studies/multimodal_rates.py " + " ".join(
            argv if argv is not None else sys.argv[1:]),
        "kinds": out, "seconds": time.time() - t0})


if __name__ == "__main__":
    main()
