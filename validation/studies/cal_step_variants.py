"""Step runs of the simulation-based calibration (``cal_coverage.py``'s
``sbc_run``: the same seeds, truths from the prior, 30 minutes at 5 Hz, 16
walkers, 200 effective samples) fitted as ``bayescal cal --kind step``
fits them and with one part of the model taken out:

* ``model``: the fit as it is (runs 0 to N-1: white self-noise on even
  runs, 1/f on odd ones; input noise on for runs 2, 3 mod 4);
* ``ar_alone``: the noise model's fractional order ``d`` held at 0 (an
  autoregression alone, at most order 20) on the 1/f runs;
* ``recorded_drive``: the model driven by the recorded input sample by
  sample instead of the step's plateaus (``bayescal/coil/drive.py``) on
  runs with input noise.

Per variant and colour: the z sd of period, damping and gain (with its
99 % chi-square band), and per run the z and the Ljung-Box p of the
innovations. Each fit's row is appended to
``<name>_runs.jsonl`` beside ``<out>`` as it finishes (not tracked) (a rerun skips rows there: resumable);
the summary goes to ``<out>``.

    python validation/studies/cal_step_variants.py --n 40 --n-drive 2
"""
from __future__ import annotations

import argparse
import json
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cal_coverage  # noqa: E402
import study_results  # noqa: E402

import bayescal.coil.step as step_module  # noqa: E402

NAMES = ("period_s", "damping", "gain")


@contextmanager
def variant(name):
    """The step model with ``name``'s part taken out while inside."""
    saved = step_module.StepModel.d_grid, step_module.step_drive
    if name == "ar_alone":
        step_module.StepModel.d_grid = (0.0,)
    elif name == "recorded_drive":
        step_module.step_drive = lambda u: u
    try:
        yield
    finally:
        step_module.StepModel.d_grid, step_module.step_drive = saved


def one(i, name, walkers, ess):
    """One run's row: config, z per parameter, Ljung-Box p, d and AR order."""
    fits = []
    fit_step = cal_coverage.fit_step

    def keep(*a, **k):
        fits.append(fit_step(*a, **k))
        return fits[-1]

    cal_coverage.fit_step = keep
    try:
        with variant(name):
            row = cal_coverage.sbc_run("step", i, walkers, ess)
    finally:
        cal_coverage.fit_step = fit_step
    ad = fits[0].adequacy
    return {"i": i, "variant": name, **row["config"], "converged": row["converged"],
            "z": {p: (e["median"] - e["truth"]) / e["sd"] for p, e in row["parameters"].items()},
            "ljung_box_p": ad.get("p_value"), "fractional_d": ad.get("fractional_d"),
            "ar_order": ad.get("ar_order")}


def summarise(rows):
    """z sd per parameter and the Ljung-Box p's median, per variant and colour."""
    out = {}
    for key in sorted({(r["variant"], r["slope"]) for r in rows}):
        sel = [r for r in rows if (r["variant"], r["slope"]) == key]
        z = np.array([[r["z"][p] for p in NAMES] for r in sel])
        n = len(sel)
        out[f"{key[0]}, slope {key[1]:g}"] = {
            "n": n, "z_sd": dict(zip(NAMES, z.std(0, ddof=1).tolist())) if n > 1 else None,
            "z_sd_band_99": [float(np.sqrt(chi2.ppf(q, n - 1) / (n - 1))) for q in (0.005, 0.995)]
            if n > 1 else None,
            "z_mean": dict(zip(NAMES, z.mean(0).tolist())),
            "z_by_run": {str(r["i"]): r["z"] for r in sel},
            "ljung_box_p_median": float(np.median([r["ljung_box_p"] for r in sel])),
            "ljung_box_p_below_0p01": int(sum(r["ljung_box_p"] < 0.01 for r in sel))}
    return out


def plan(n, n_drive):
    """(run, variant) in the order run: each run's variants after it."""
    drive = [i for i in range(n) if (i // 2) % 2][:n_drive]
    return [(i, name) for i in range(n) for name in ("model", "ar_alone", "recorded_drive")
            if name == "model" or (name == "ar_alone" and i % 2) or (name != "ar_alone" and i in drive)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--n-drive", type=int, default=2)
    ap.add_argument("--walkers", type=int, default=16)
    ap.add_argument("--ess", type=int, default=200)
    ap.add_argument("--out", default="validation/results/cal/step_variants.json")
    args = ap.parse_args()
    path = Path(args.out).with_name(Path(args.out).stem + "_runs.jsonl")
    rows = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
    done = {(r["i"], r["variant"]) for r in rows}
    path.parent.mkdir(parents=True, exist_ok=True)
    todo = plan(args.n, args.n_drive)
    for i, name in todo:
        if (i, name) in done:
            continue
        rows.append(one(i, name, args.walkers, args.ess))
        with open(path, "a") as fh:
            fh.write(json.dumps(rows[-1]) + "\n")
    rows = [r for r in rows if (r["i"], r["variant"]) in set(todo)]
    out = {"command": f"python validation/studies/cal_step_variants.py --n {args.n} "
                      f"--n-drive {args.n_drive}",
           "sampler": {"n_walkers": args.walkers, "min_ess": args.ess},
           "variants": summarise(rows)}
    study_results.write(args.out, out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
