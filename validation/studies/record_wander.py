"""The record's value from ten-minute windows with a wander between them
(:mod:`bayescal.record`), on the COWI record and on simulated records.

COWI (``--part cowi``): the 102 ten-minute windows 2010-08-23T22:00 -
2010-08-24T15:00 of the ASL COWI pair, band 1/8-1/3 Hz, fitted as
``short_windows.py`` fits them (flat metadata, window k with seed k,
transients left out, no criticism) but through
:func:`bayescal.record.fit_windows`; per channel (LHN, LHE azimuths) the wander
model (:func:`bayescal.record.fit_wander`) and the issue's four checks on
the windows' intervals for the record's value:

* median width over the window's Fisher bound at most 1.1 times the
  scatter over the bound (``short_windows.py``'s ``scatter_over_bound``);
* no window's interval narrower than its bound (the bounds of
  ``short_windows.runs.json``: the same windows, segments and seeds);
* the whole record's fit (``short_windows.json``) inside the windows'
  95 % intervals at the binomial rate (at least 90 of 102);
* the repeatability ratio of the windows' medians against the intervals'
  sds (half the 95 % width over 1.96) inside [0.82, 1.18].

Out of sample: tau and ell's posterior learned from one half of the
windows, the other half's intervals widened by it, the whole record's value
counted inside them.

Simulation (``--part sim``): records of 24 ten-minute windows, each window
a pair from :func:`bayescal.simulate.simulate_pair` whose SUT azimuths are
the truth plus an OU wander ``w(t_i)`` (tau 0, 0.05 or 0.2 deg, time scale
2 h), at two SNRs and two reference noises; per record the record value's
95 % interval and one window's (drawn before the fit) interval for it,
counted against the truth.

    python validation/studies/record_wander.py --part cowi      # fits 102 windows (~5 min)
    python validation/studies/record_wander.py --part cowi --summarise
    python validation/studies/record_wander.py --part sim --records 8
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import study_results                          # the sibling module, run as a script
import short_windows                          # the sibling module: the COWI settings and checks

from scipy.stats import binom

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "validation" / "results" / "repeatability"
COWI_OUT = RESULTS / "record_wander_cowi.json"
SIM_OUT = RESULTS / "record_wander_sim.json"
CHANNELS = ("LHN", "LHE")
#: Quantile levels of each window's posterior kept in the runs file (its samples' shape).
LEVELS = np.linspace(0.0, 1.0, 201)


def cowi_windows():
    """Fit the 102 COWI windows through :func:`bayescal.record.fit_windows`;
    per window its start and, per channel, median, ci68, ci95 and the
    quantiles :data:`LEVELS` of its samples (or the reason it was skipped)."""
    from obspy import UTCDateTime

    from bayescal.io import flat_inventory, read_waveforms
    from bayescal.record import fit_windows
    cowi = short_windows.COWI
    sut = read_waveforms(str(cowi / "C100823215422_COWI.LHx"))
    ref = read_waveforms([str(cowi / "DT000110.LH1"), str(cowi / "DT000110.LH2")])

    def said(k, n, w):
        print(f"{k + 1}/{n} {w.start} {w.reason or ''}", flush=True)

    ws = fit_windows(ref=ref, ref_xml=flat_inventory(ref), sut=sut, sut_xml=flat_inventory(sut),
                     start=UTCDateTime(short_windows.START), end=UTCDateTime(short_windows.END),
                     window=600.0, band=short_windows.BAND, diagnose=False, on_window=said)
    rows = []
    for w in ws:
        row = {"start": str(w.start)[:19]}
        if not w.fitted:
            row["reason"] = w.reason
        for c in CHANNELS if w.fitted else ():
            name = f"US.COWI..{c}:azimuth_deg"
            row[c] = {**w.values[name],
                      "quantiles": np.quantile(w.samples[name], LEVELS).tolist()}
        rows.append(row)
    return rows



def draws_from_quantiles(quantiles, rng, n=4000):
    """``n`` draws of a window's posterior from its stored quantiles
    (:data:`LEVELS`), by the inverse distribution function."""
    return np.interp(rng.uniform(size=n), LEVELS, quantiles)


def record_intervals(rows, c, fit, rng):
    """The windows' 95 % intervals for the record's value: each window's
    draws plus the wander's, ``tau`` from ``fit``'s posterior."""
    from bayescal.record import widen_samples
    return np.array([np.percentile(widen_samples(draws_from_quantiles(r[c]["quantiles"], rng),
                                                 fit.tau_grid, fit.tau_weights, rng),
                                   [2.5, 97.5]) for r in rows])


def checks(rows, c, intervals, bounds, whole):
    """``short_windows.channel_summary`` on the intervals ``(n, 2)`` (sd: half
    the 95 % width over 1.96), with each window's bound."""
    entries = [{c: {"median": r[c]["median"], "ci95": list(ci), "sd68": (ci[1] - ci[0]) / 3.92,
                "bound_sd": bounds[r["start"]][c]["bound_sd"],
                "bound_width95": bounds[r["start"]][c]["bound_width95"]}}
               for r, ci in zip(rows, intervals)]
    return short_windows.channel_summary(entries, c, whole)


def out_of_sample(rows, c, t, whole, rng):
    """tau's posterior from one half of the windows, the other half's
    intervals widened by it: the whole record's value inside them."""
    from bayescal.record import fit_wander
    half = len(rows) // 2
    out = {}
    for name, learn, apply in (("first_to_second", slice(0, half), slice(half, None)),
                               ("second_to_first", slice(half, None), slice(0, half))):
        x = np.array([r[c]["median"] for r in rows])
        sd = np.array([np.diff(r[c]["ci68"])[0] / 2 for r in rows])
        fit = fit_wander(x[learn], sd[learn], t[learn])
        ci = record_intervals(rows[apply], c, fit, rng)
        held = int(np.sum((ci[:, 0] <= whole) & (whole <= ci[:, 1])))
        out[name] = {"windows": len(ci), "holds_whole_record": held,
                     "holds_min": short_windows.hold_min(len(ci)),
                     "tau_median": fit.tau["median"], "ell_median_h": fit.ell["median"] / 3600,
                     "ok": held >= short_windows.hold_min(len(ci))}
    return out


def cowi_channel(rows, c, bounds, whole, rng):
    """One channel's wander model, the four checks on its windows' intervals
    for the record's value (and on the windows' own), the shown windows and
    the out-of-sample check."""
    from bayescal.record import fit_wander
    from obspy import UTCDateTime
    t0 = UTCDateTime(rows[0]["start"])
    t = np.array([UTCDateTime(r["start"]) - t0 + 300.0 for r in rows])
    x = np.array([r[c]["median"] for r in rows])
    sd = np.array([np.diff(r[c]["ci68"])[0] / 2 for r in rows])
    fit = fit_wander(x, sd, t)
    rec = record_intervals(rows, c, fit, rng)
    own = np.array([r[c]["ci95"] for r in rows])
    shown = {r["start"]: {"width95": float(own[i, 1] - own[i, 0]),
                          "record_width95": float(rec[i, 1] - rec[i, 0]),
                          "bound_width95": bounds[r["start"]][c]["bound_width95"]}
             for i, r in enumerate(rows) if r["start"] in short_windows.SHOWN}
    return {"record_value": fit.mu, "whole_record": whole,
            "record_minus_whole": fit.mu["median"] - whole,
            "tau_deg": fit.tau, "ell_h": {k: (np.asarray(v) / 3600).tolist()
                                          for k, v in fit.ell.items()},
            "ratio_without": fit.ratio_without, "ratio_with": fit.ratio_with,
            "record_intervals": checks(rows, c, rec, bounds, whole),
            "window_intervals": checks(rows, c, own, bounds, whole),
            "shown": shown, "out_of_sample": out_of_sample(rows, c, t, whole, rng)}


def cowi_summary(rows):
    """Per channel :func:`cowi_channel`, with the bounds and the whole
    record's value of ``short_windows``' stored results."""
    sw = study_results.read(RESULTS / "short_windows.json")
    bounds = {r["start"][:19]: r["drop"] for r in sw["runs"]}
    ok = [r for r in rows if "LHN" in r]
    rng = np.random.default_rng(41)
    out = {c: cowi_channel(ok, c, bounds, sw["whole_record"]["drop"][c], rng) for c in CHANNELS}
    out["windows"], out["skipped"] = len(ok), [r for r in rows if "LHN" not in r]
    out["max_median_difference_from_short_windows"] = float(max(
        abs(r[c]["median"] - bounds[r["start"]][c]["median"]) for r in ok for c in CHANNELS))
    return out

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=["cowi", "sim"], required=True)
    ap.add_argument("--summarise", action="store_true",
                    help="recompute the summary from the runs stored beside the output")
    ap.add_argument("--records", type=int, default=8, help="simulated records per setting")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    if args.part == "cowi":
        if args.summarise:
            doc = study_results.read(COWI_OUT)
        else:
            doc = {"command": "python validation/studies/record_wander.py --part cowi",
                   "runs": cowi_windows()}
            study_results.write(COWI_OUT, doc)
        doc["summary"] = cowi_summary(doc["runs"])
        study_results.write(COWI_OUT, doc)
        print(json.dumps(doc["summary"], indent=1))
    else:
        sim_main(args)


if __name__ == "__main__":
    main()
