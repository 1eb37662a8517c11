"""Power of the tilt-noise test (:func:`bayescal.criticism.tilt.tilt_test`) against the
old coherence-ratio rule (:func:`bayescal.effects.tilt_signature`), on the
same simulated pairs.

Each of ``--n`` seeds draws, as ``diagnose_harness.py`` does, a
coherence uniform in 0.9-0.995, a random azimuth and a tilt-noise level
log-uniform in 5-100, and simulates the pair twice (3600 s at 10 Hz, band
0.02-3 Hz): clean and with tilt noise on SUT channels 0 and 1 (same seed, so
the same ground motion). Both rules judge both spectra. Reported: the
detection rate per level bin (kept / kept with both horizontals named) and
the false-alarm rate on the clean runs, for the new test (default; on the
pipeline's own coarser bands; with the tilt noise-to-signal ratio instead of
the tilt power as the power law) and the old rule; also the recovered exponent alpha
(truth 2 for the ``psd`` shape: the simulator's tilt noise power falls as
f^-2) and how often its 95 % interval covers 2.

    python validation/studies/tilt_power.py --n 200 --out validation/results/diagnose/tilt_power.json
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.simulate.harness import tilt_pair_spectra as pair_spectra

BAND = (0.02, 3.0)
LEVEL_BINS = (5, 7, 10, 20, 50, 100)
HORIZONTAL = np.array([True, True, False])
#: The new test's variants: default; the pipeline's own (coarser) bands; the
#: brief's form (tilt noise-to-signal ratio, not tilt power, ~ f^-alpha).
VARIANTS = {"psd": {}, "coarse": {"fine": None}, "nsr": {"shape": "nsr"}}
RULES = tuple(VARIANTS) + ("old",)


def judge(sp):
    """Verdicts of the new test (both shapes) and of the old rule."""
    from bayescal.criticism import effects
    from bayescal.criticism.locate import band_coherence
    from bayescal.criticism.tilt import tilt_test

    out = {}
    for name, kw in VARIANTS.items():
        t = tilt_test(sp, HORIZONTAL, **kw)
        out[name] = {"kept": t["kept"], "channels": t["channels"], "delta_bic": t["delta_bic"],
                      "alpha": t["alpha"], "phi": t["phi"]}
    old = effects.tilt_signature(sp.band_centres, band_coherence(sp), HORIZONTAL)
    out["old"] = {"kept": bool(old["channels"]), "channels": old["channels"],
                  "score": old["score"]}
    return out


def run_one(seed, levels=(5.0, 100.0)):
    """One seed: clean and tilt runs; returns the record."""
    rng = np.random.default_rng(seed)
    level = float(np.exp(rng.uniform(*np.log(levels))))
    coherence = float(rng.uniform(0.9, 0.995))
    azimuth = float(rng.uniform(0, 360))
    return {"seed": seed, "level": level, "coherence": coherence, "azimuth": azimuth,
            "clean": judge(pair_spectra(seed, coherence, azimuth, 0.0)),
            "tilt": judge(pair_spectra(seed, coherence, azimuth, level))}


def summarise(records, bins=LEVEL_BINS):
    """Detection rates per level bin, false-alarm rates, alpha recovery."""
    rules = RULES
    both = lambda v: v["kept"] and sorted(v["channels"]) == [0, 1]     # noqa: E731
    rows = []
    for lo, hi in zip(bins[:-1], bins[1:]):
        sel = [r for r in records if lo <= r["level"] < hi]
        rows.append({"level": [lo, hi], "runs": len(sel),
                     **{rule: {"detected": sum(r["tilt"][rule]["kept"] for r in sel),
                               "both_horizontals": sum(both(r["tilt"][rule]) for r in sel)}
                        for rule in rules}})
    false = {rule: sum(r["clean"][rule]["kept"] for r in records) for rule in rules}
    kept = [r["tilt"]["psd"] for r in records if r["tilt"]["psd"]["kept"]]
    alpha = np.array([k["alpha"]["median"] for k in kept])
    cover = sum(k["alpha"]["ci95"][0] <= 2.0 <= k["alpha"]["ci95"][1] for k in kept)
    clean_dbic = np.array([r["clean"]["psd"]["delta_bic"] for r in records])
    return {"by_level": rows, "false_alarms": false, "clean_runs": len(records),
            "alpha_psd": {"runs_kept": len(kept),
                          "median": float(np.median(alpha)) if kept else None,
                          "iqr": np.percentile(alpha, [25, 75]).tolist() if kept else None,
                          "ci95_covers_2": int(cover)},
            "clean_delta_bic_psd": {"max": float(clean_dbic.max()),
                                    "median": float(np.median(clean_dbic))}}


def markdown(s, seconds):
    lines = ["| tilt level | runs | new: kept / both H | new, pipeline bands | new, NSR form | "
             "old rule |", "|---|---|---|---|---|---|"]
    for r in s["by_level"]:
        cells = [f"{r[k]['detected']} / {r[k]['both_horizontals']}" for k in RULES]
        lines.append(f"| {r['level'][0]}-{r['level'][1]} | {r['runs']} | " + " | ".join(cells)
                     + " |")
    n = s["clean_runs"]
    fa = s["false_alarms"]
    lines.append(f"| clean (false alarms) | {n} | " + " | ".join(str(fa[k]) for k in RULES) + " |")
    a = s["alpha_psd"]
    lines.append("")
    lines.append(f"alpha (psd shape, truth 2) over {a['runs_kept']} kept runs: median "
                 f"{a['median']}, IQR {a['iqr']}, 95 % interval covers 2 in {a['ci95_covers_2']}; "
                 f"clean delta BIC max {s['clean_delta_bic_psd']['max']:.1f}, median "
                 f"{s['clean_delta_bic_psd']['median']:.1f}; {seconds:.0f} s in all")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="number of seeds (each: clean + tilt)")
    ap.add_argument("--first-seed", type=int, default=5000)
    ap.add_argument("--levels", type=float, nargs=2, default=(5.0, 100.0),
                    help="tilt levels drawn log-uniform between these (5 100)")
    ap.add_argument("--out", default="validation/results/diagnose/tilt_power.json")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    records = []
    for k in range(args.n):
        rec = run_one(args.first_seed + k, args.levels)
        records.append(rec)
        print(f"{k + 1:3d} seed {rec['seed']} level {rec['level']:5.1f} coh {rec['coherence']:.3f}"
              f" | clean dBIC {rec['clean']['psd']['delta_bic']:6.1f} | tilt dBIC "
              f"{rec['tilt']['psd']['delta_bic']:6.1f} ch {rec['tilt']['psd']['channels']} "
              f"old {rec['tilt']['old']['channels']}", file=sys.stderr, flush=True)
    seconds = time.perf_counter() - t0
    bins = (LEVEL_BINS if tuple(args.levels) == (5.0, 100.0)
            else tuple(float(f"{x:.2g}") for x in np.geomspace(*args.levels, 5)))
    s = summarise(records, bins)
    text = markdown(s, seconds)
    print(text)
    study_results.write(args.out, {"runs": records, "summary": s, "markdown": text, "seconds": seconds,
                          "settings": {"duration_s": 3600, "fs": 10, "band_hz": BAND,
                                       "level": f"log-uniform {args.levels[0]:g}-"
                                                f"{args.levels[1]:g}",
                                       "coherence": "uniform 0.9-0.995",
                                       "horizontal": HORIZONTAL.tolist()}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
