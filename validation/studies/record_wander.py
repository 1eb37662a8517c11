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

The model alone (``--part model``): window estimates drawn from the model
itself in nine regimes (no wander, a small one and a large one; time
scales below the spacing, of a few spacings, and of half the record), 200
records each: how often the record value's and a window's intervals hold
the truth.

Simulation (``--part sim``): records of 24 ten-minute windows, each window
a pair from :func:`bayescal.simulate.simulate_pair` whose SUT azimuths are
the truth plus an OU wander ``w(t_i)`` (tau 0, 0.05 or 0.2 deg, time scale
2 h), at two SNRs and two reference noises; per record the record value's
95 % interval and one window's (drawn before the fit) interval for it,
counted against the truth.

    python validation/studies/record_wander.py --part cowi      # fits 102 windows (~5 min)
    python validation/studies/record_wander.py --part cowi --summarise
    python validation/studies/record_wander.py --part sim --records 180   # resumable, ~40 min
    python validation/studies/record_wander.py --part model    # the model alone, ~4 min

The parts above fit each window as ``bayescal fit`` does (``--likelihood
per-band``). ``--likelihood gaussian`` (parts cowi and sim; ``bayescal
windows``' default): each window fitted with the Gaussian likelihood
(``misfit_shape=inf``), the windows below the record's median noise
inflation fitted again with it as a floor (:mod:`bayescal.record.pooling`),
and the record model's common factor on the windows' sds learned
(``learn_scale``); on COWI the windows' first fits (no floor) are
summarised too (``without_floor``), with the floor and the correlation of
the first fits' width / bound with their inflation (``pooling``). The
results go to ``record_wander_cowi_gaussian.json`` and
``record_wander_sim_gaussian.json``:

    python validation/studies/record_wander.py --part cowi --likelihood gaussian   # ~2 min
    python validation/studies/record_wander.py --part sim --records 180 --likelihood gaussian   # ~60 min
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
#: Each window's likelihood (``--likelihood``): the fit's keywords, and the output's suffix.
LIKELIHOODS = {"per-band": {}, "gaussian": {"misfit_shape": float("inf"), "pool_inflation": True}}
SIM_OUT = RESULTS / "record_wander_sim.json"
CHANNELS = ("LHN", "LHE")
#: The prior's longest time scale (in record spans) of the sensitivity check.
SENSITIVITY_ELL_MAX = 1.0
#: The learned factor's prior reaching below one (its lower end, grid points) in a second check.
SENSITIVITY_SCALE_MIN, SENSITIVITY_N_SCALE = 0.5, 43
#: Quantile levels of each window's posterior kept in the runs file (its samples' shape).
LEVELS = np.linspace(0.0, 1.0, 201)


def cowi_windows(likelihood="per-band"):
    """Fit the 102 COWI windows through :func:`bayescal.record.fit_windows`
    (``likelihood``: a key of :data:`LIKELIHOODS`); per window its start
    and, per channel, median, ci68, ci95 and the quantiles :data:`LEVELS`
    of its samples (or the reason it was skipped); with the record's
    inflation floor (gaussian), each band's inflation of its first fit,
    whether it was fitted again with the floor, and its first fit's
    values per channel (``first``)."""
    from obspy import UTCDateTime

    from bayescal.io import flat_inventory, read_waveforms
    from bayescal.record import fit_windows
    cowi = short_windows.COWI
    sut = read_waveforms(str(cowi / "C100823215422_COWI.LHx"))
    ref = read_waveforms([str(cowi / "DT000110.LH1"), str(cowi / "DT000110.LH2")])

    first = {}

    def said(k, n, w):
        first.setdefault(k, w)
        print(f"{k + 1}/{n} {w.start} {w.reason or ''}{' (floored)' if w.floored else ''}",
              flush=True)

    ws = fit_windows(ref=ref, ref_xml=flat_inventory(ref), sut=sut, sut_xml=flat_inventory(sut),
                     start=UTCDateTime(short_windows.START), end=UTCDateTime(short_windows.END),
                     window=600.0, band=short_windows.BAND, diagnose=False, on_window=said,
                     **LIKELIHOODS[likelihood])
    rows = []
    for k, w in enumerate(ws):
        row = {"start": str(w.start)[:19]}
        if not w.fitted:
            row["reason"] = w.reason
            rows.append(row)
            continue
        pooled = w.floor is not None
        if pooled:
            row.update(inflation=first[k].inflation.tolist(), floored=w.floored)
        for c in CHANNELS:
            row[c] = window_values(w, c)
            if pooled:
                row[c]["first"] = window_values(first[k], c)
        rows.append(row)
    return rows


def window_values(w, c):
    """Channel ``c``'s azimuth in window ``w``: median, ci68, ci95 and the
    quantiles :data:`LEVELS` of its samples."""
    name = f"US.COWI..{c}:azimuth_deg"
    return {**w.values[name], "quantiles": np.quantile(w.samples[name], LEVELS).tolist()}



def draws_from_quantiles(quantiles, rng, n=40000):
    """``n`` draws of a window's posterior from its stored quantiles
    (:data:`LEVELS`), by the inverse distribution function."""
    return np.interp(rng.uniform(size=n), LEVELS, quantiles)


def record_intervals(rows, c, fit, rng):
    """The windows' 95 % intervals for the record's value: each window's
    draws (scaled about their median by ``lambda``) plus the wander's,
    ``(lambda, tau)`` from ``fit``'s posterior."""
    from bayescal.record import widen_samples
    return np.array([np.percentile(widen_samples(draws_from_quantiles(r[c]["quantiles"], rng),
                                                 fit.tau_grid, fit.scale_tau_weights, rng,
                                                 fit.scale_grid),
                                   [2.5, 97.5]) for r in rows])


def checks(rows, c, intervals, bounds, whole):
    """``short_windows.channel_summary`` on the intervals ``(n, 2)`` (sd: half
    the 95 % width over 1.96), with each window's bound."""
    entries = [{c: {"median": r[c]["median"], "ci95": list(ci), "sd68": (ci[1] - ci[0]) / 3.92,
                "bound_sd": bounds[r["start"]][c]["bound_sd"],
                "bound_width95": bounds[r["start"]][c]["bound_width95"]}}
               for r, ci in zip(rows, intervals)]
    return short_windows.channel_summary(entries, c, whole)


def out_of_sample(rows, c, t, whole, rng, learn_scale=False):
    """tau's (and lambda's) posterior from one half of the windows, the
    other half's intervals widened by it: the whole record's value inside them."""
    from bayescal.record import fit_wander
    half = len(rows) // 2
    out = {}
    for name, learn, apply in (("first_to_second", slice(0, half), slice(half, None)),
                               ("second_to_first", slice(half, None), slice(0, half))):
        x = np.array([r[c]["median"] for r in rows])
        sd = np.array([np.diff(r[c]["ci68"])[0] / 2 for r in rows])
        fit = fit_wander(x[learn], sd[learn], t[learn], learn_scale=learn_scale)
        ci = record_intervals(rows[apply], c, fit, rng)
        held = int(np.sum((ci[:, 0] <= whole) & (whole <= ci[:, 1])))
        out[name] = {"windows": len(ci), "holds_whole_record": held,
                     "holds_min": short_windows.hold_min(len(ci)),
                     "tau_median": fit.tau["median"], "ell_median_h": fit.ell["median"] / 3600,
                     "scale_median": fit.scale["median"],
                     "ok": held >= short_windows.hold_min(len(ci))}
    return out


def cowi_channel(rows, c, bounds, whole, rng, learn_scale=False):
    """One channel's wander model, the four checks on its windows' intervals
    for the record's value (and on the windows' own), the shown windows and
    the out-of-sample check."""
    from bayescal.record import fit_wander
    from obspy import UTCDateTime
    t0 = UTCDateTime(rows[0]["start"])
    t = np.array([UTCDateTime(r["start"]) - t0 + 300.0 for r in rows])
    x = np.array([r[c]["median"] for r in rows])
    sd = np.array([np.diff(r[c]["ci68"])[0] / 2 for r in rows])
    fit = fit_wander(x, sd, t, learn_scale=learn_scale)
    rec = record_intervals(rows, c, fit, rng)
    own = np.array([r[c]["ci95"] for r in rows])
    shown = {r["start"]: {"width95": float(own[i, 1] - own[i, 0]),
                          "record_width95": float(rec[i, 1] - rec[i, 0]),
                          "bound_width95": bounds[r["start"]][c]["bound_width95"]}
             for i, r in enumerate(rows) if r["start"] in short_windows.SHOWN}
    return {"record_value": fit.mu, "whole_record": whole,
            "record_minus_whole": fit.mu["median"] - whole,
            "tau_deg": fit.tau, "scale": fit.scale, "ell_h": {k: (np.asarray(v) / 3600).tolist()
                                          for k, v in fit.ell.items()},
            "ratio_without": fit.ratio_without, "ratio_with": fit.ratio_with,
            "record_intervals": checks(rows, c, rec, bounds, whole),
            "window_intervals": checks(rows, c, own, bounds, whole),
            "shown": shown, "out_of_sample": out_of_sample(rows, c, t, whole, rng, learn_scale)}


def cowi_summary(rows, learn_scale=False):
    """Per channel :func:`cowi_channel`, with the bounds and the whole
    record's value of ``short_windows``' stored results (``learn_scale``:
    the common factor on the windows' sds learned)."""
    sw = study_results.read(RESULTS / "short_windows.json")
    bounds = {r["start"][:19]: r["drop"] for r in sw["runs"]}
    ok = [r for r in rows if "LHN" in r]
    from bayescal.record import wander
    rng = np.random.default_rng(41)
    out = {c: cowi_channel(ok, c, bounds, sw["whole_record"]["drop"][c], rng, learn_scale)
           for c in CHANNELS}
    default, wander.ELL_MAX = wander.ELL_MAX, SENSITIVITY_ELL_MAX
    try:
        out["ell_max_sensitivity"] = {"ell_max_spans": SENSITIVITY_ELL_MAX, **{
            c: cowi_channel(ok, c, bounds, sw["whole_record"]["drop"][c], rng, learn_scale)
            for c in CHANNELS}}
    finally:
        wander.ELL_MAX = default
    if ok and all("first" in r["LHN"] for r in ok):       # the windows as first fitted: no floor
        firsts = [{"start": r["start"], **{c: r[c]["first"] for c in CHANNELS}} for r in ok]
        out["without_floor"] = {c: cowi_channel(firsts, c, bounds, sw["whole_record"]["drop"][c],
                                                rng, learn_scale) for c in CHANNELS}
        out["pooling"] = pooling_summary(ok, bounds)
    if learn_scale:                 # the factor's prior reaching below one: what its end costs
        kept = wander.SCALE_MIN, wander.N_SCALE
        wander.SCALE_MIN, wander.N_SCALE = SENSITIVITY_SCALE_MIN, SENSITIVITY_N_SCALE
        try:
            out["scale_min_sensitivity"] = {"scale_min": SENSITIVITY_SCALE_MIN, **{
                c: cowi_channel(ok, c, bounds, sw["whole_record"]["drop"][c], rng, learn_scale)
                for c in CHANNELS}}
        finally:
            wander.SCALE_MIN, wander.N_SCALE = kept
    out["ell_max_spans"], out["learn_scale"] = default, learn_scale
    out["windows"], out["skipped"] = len(ok), [r for r in rows if "LHN" not in r]
    out["max_median_difference_from_short_windows"] = float(max(
        abs(r[c]["median"] - bounds[r["start"]][c]["median"]) for r in ok for c in CHANNELS))
    return out


def pooling_summary(rows, bounds):
    """The record's inflation floor on COWI: the floor per band, how many
    windows were fitted again with it, and per channel the correlation over
    the windows of the first fit's log width / bound with each band's log
    inflation (the width follows the inflation its segments measured)."""
    infl = np.log(np.array([r["inflation"] for r in rows]))
    corr = {}
    for c in CHANNELS:
        q = np.log([np.diff(r[c]["first"]["ci95"])[0] / bounds[r["start"]][c]["bound_width95"]
                    for r in rows])
        corr[c] = [float(np.corrcoef(q, infl[:, b])[0, 1]) for b in range(infl.shape[1])]
    return {"floored": sum(r["floored"] for r in rows),
            "floor": np.median([r["inflation"] for r in rows], axis=0).tolist(),
            "corr_log_width_over_bound_log_inflation": corr,
            "thirds": inflation_thirds(rows, bounds, infl[:, -1])}


def inflation_thirds(rows, bounds, log_top):
    """The windows split in thirds by their first fit's inflation in the
    highest band (``log_top``, log): per third and channel, the rms of
    (median - whole record) over the bound's sd, and the median of the
    window's own sd (half its 95 % width over 1.96) over the bound's sd,
    before the floor and after it."""
    sw = study_results.read(RESULTS / "short_windows.json")["whole_record"]["drop"]
    out = []
    for part in np.array_split(np.argsort(log_top), 3):
        entry = {"inflation_range": [float(np.exp(log_top[part].min())),
                                     float(np.exp(log_top[part].max()))]}
        for c in CHANNELS:
            b = np.array([bounds[rows[i]["start"]][c]["bound_sd"] for i in part])
            err = np.array([rows[i][c]["median"] - sw[c] for i in part]) / b
            sd = {k: np.array([np.diff(v["ci95"])[0] / 3.92 for v in
                               (rows[i][c] if k == "floored" else rows[i][c]["first"]
                                for i in part)]) / b for k in ("first", "floored")}
            entry[c] = {"rms_error_over_bound": float(np.sqrt(np.mean(err ** 2))),
                        **{f"median_sd_over_bound_{k}": float(np.median(v))
                           for k, v in sd.items()}}
        out.append(entry)
    return out


#: The simulated settings: wander sd (deg), then (SUT coherence, reference coherence).
TAUS = (0.0, 0.05, 0.2)
NOISES = ((0.999, 0.9999), (0.999, 0.999), (0.99, 0.9999), (0.99, 0.999))
#: Windows per record, their length (s), the wander's time scale (s), the band (Hz).
N_WINDOWS, WINDOW_S, ELL_S, SIM_BAND = 24, 600.0, 7200.0, (0.1, 0.8)


#: ``--varied``: what real records vary, cycled over blocks of twelve records
#: (each block every wander and noise setting): the simulator's keywords,
#: and whether every other window carries a burst of noise in the SUT.
VARIANTS = {"steep ground": ({"ground": "steep-microseism"}, False),
            "noise in counts": ({"noise_in_counts": True}, False),
            "two plane waves": ({"n_waves": 2, "diffuse": 0.05}, False),
            "bursts": ({}, True)}
#: A burst: its length (s) and its noise's sd over the SUT trace's own.
BURST_S, BURST_SD = 120.0, 1.0


def sim_variant(r):
    """Record ``r``'s variant under ``--varied`` (a key of :data:`VARIANTS`)."""
    return list(VARIANTS)[(r // (len(TAUS) * len(NOISES))) % len(VARIANTS)]


def add_burst(sut, rng):
    """Add to each horizontal SUT trace (MH1, MH2) a burst of white noise,
    :data:`BURST_S` long at a random time, its sd :data:`BURST_SD` times the
    trace's own: noise that is not stationary within the window."""
    for tr in sut.select(channel="MH[12]"):
        n = int(BURST_S * tr.stats.sampling_rate)
        a = int(rng.integers(0, len(tr.data) - n))
        tr.data = tr.data.astype(float)
        tr.data[a:a + n] += rng.normal(0.0, BURST_SD * np.std(tr.data), n)


def sim_setting(r):
    """Record ``r``'s setting: (tau, (coherence, reference coherence)),
    cycling through all twelve so that any first records are balanced."""
    return TAUS[r % len(TAUS)], NOISES[(r // len(TAUS)) % len(NOISES)]


def sim_record(r, likelihood="per-band", varied=False):
    """One simulated record: 24 windows, each a pair whose SUT is turned by
    the truth plus the wander at its time (fitted with ``likelihood``, a key
    of :data:`LIKELIHOODS`; gaussian: the common scale learned; ``varied``:
    the record's :func:`sim_variant`); the wander model per horizontal
    channel; what holds the truth."""
    from bayescal.record import combine, draw_wander
    from bayescal.record.windows import fit_window
    from bayescal.simulate import simulate_pair
    from obspy import UTCDateTime
    tau, (coh, ref_coh) = sim_setting(r)
    rng = np.random.default_rng(1000 + r)
    az0 = rng.uniform(-5.0, 5.0)
    w = draw_wander(np.arange(N_WINDOWS) * WINDOW_S, tau, ELL_S, rng)
    drawn = int(rng.integers(N_WINDOWS))
    options = dict(LIKELIHOODS[likelihood])
    pool = options.pop("pool_inflation", False)
    variant = sim_variant(r) if varied else None
    sim_kw, bursts = VARIANTS[variant] if varied else ({}, False)
    pairs = []
    for i in range(N_WINDOWS):
        t0 = UTCDateTime(2026, 1, 1) + i * WINDOW_S
        p = simulate_pair(duration=WINDOW_S, fs=2.0, seed=100000 * r + i, coherence=coh,
                          ref_coherence=ref_coh, sut_azimuth=(az0 + w[i], az0 + 90 + w[i], 0.0),
                          start=t0, **sim_kw)
        if bursts and i % 2:
            add_burst(p.sut, np.random.default_rng([r, i]))
        pairs.append(((p.ref, p.ref_inventory, p.sut, p.sut_inventory), t0))

    def fitted(i, **extra):
        pair, t0 = pairs[i]
        return fit_window(pair, t0, t0 + WINDOW_S, i, band=SIM_BAND, diagnose=False,
                          progress=False, **options, **extra)

    windows = [fitted(i) for i in range(N_WINDOWS)]
    if pool:                          # as fit_windows does (bayescal.record.pooling)
        from bayescal.record.pooling import floor_windows
        windows = floor_windows(windows, lambda i, floor: fitted(i, inflation_floor=floor))
    recs = combine(windows, seed=r, learn_scale=likelihood == "gaussian")
    out = {"record": r, "tau": tau, "coherence": coh, "ref_coherence": ref_coh, "drawn": drawn,
           "skipped": sum(not win.fitted for win in windows),
           **({"variant": variant} if varied else {})}
    for ch, truth in (("MH1", az0), ("MH2", az0 + 90.0)):
        rec = recs[f"XX.SIM.10.{ch}:azimuth_deg"]
        truth += 360.0 * np.round((rec.fit.mu["median"] - truth) / 360.0)   # SEED's 0-360
        lo, hi = rec.fit.mu["ci95"]
        k = min(drawn, len(rec.medians) - 1)
        out[ch] = {"mu_holds": bool(lo <= truth <= hi), "mu_z": (rec.fit.mu["median"] - truth)
                   / rec.fit.mu["sd"], "window_holds": bool(rec.record_ci95[k, 0] <= truth
                                                             <= rec.record_ci95[k, 1]),
                   "own_holds_truth": bool(rec.ci95[k, 0] <= truth <= rec.ci95[k, 1]),
                   "tau_median": rec.fit.tau["median"],
                   "scale_median": rec.fit.scale["median"], "median_sd68": float(np.median(
                       [np.diff(win.values[f"XX.SIM.10.{ch}:azimuth_deg"]["ci68"])[0] / 2
                        for win in windows if win.fitted]))}
    return out


def sim_summary(runs):
    """Per wander sd and over all: the record values' and the drawn
    windows' intervals holding the truth (one channel per record, MH1 for
    even records and MH2 for odd, so the counts are independent), with the
    two-sided 99 % binomial band."""
    out = {}
    groups = {f"tau_{tau:g}": [x for x in runs if x["tau"] == tau] for tau in TAUS}
    groups.update({v: [x for x in runs if x.get("variant") == v] for v in VARIANTS})
    groups["all"] = runs
    for name, rows in groups.items():
        if not rows:
            continue
        one = [x["MH1" if x["record"] % 2 == 0 else "MH2"] for x in rows]
        n = len(one)
        band = [int(binom.ppf(0.005, n, 0.95)), int(binom.ppf(0.995, n, 0.95))]
        counts = {key: int(sum(o[key] for o in one))
                  for key in ("mu_holds", "window_holds", "own_holds_truth")}
        out[name] = {"records": n, **counts, "band99": band,
                     "mu_in_band": band[0] <= counts["mu_holds"] <= band[1],
                     "window_in_band": band[0] <= counts["window_holds"] <= band[1],
                     "mu_z_sd": float(np.std([o["mu_z"] for o in one])),
                     "median_window_sd68": float(np.median([o["median_sd68"] for o in one])),
                     "median_tau": float(np.median([o["tau_median"] for o in one])),
                     "median_scale": float(np.median([o.get("scale_median", 1.0) for o in one]))}
    return out


def sim_main(args):
    """Run records until ``args.records`` are stored (resumable), then summarise."""
    name = ("record_wander_sim" + ("" if args.likelihood == "per-band" else f"_{args.likelihood}")
            + ("_varied" if args.varied else ""))
    out = SIM_OUT.with_name(f"{name}.json")
    doc = study_results.read(out) if (out.exists() or study_results.runs_path(
        out).exists()) else {"runs": []}
    flag = ("" if args.likelihood == "per-band" else f" --likelihood {args.likelihood}") \
        + (" --varied" if args.varied else "")
    doc.update(command=f"python validation/studies/record_wander.py --part sim --records "
                       f"{args.records}{flag}", likelihood=args.likelihood, settings={"taus_deg": TAUS, "noises": NOISES,
                                                    "windows": N_WINDOWS, "window_s": WINDOW_S,
                                                    "ell_s": ELL_S, "band_hz": SIM_BAND,
                                                    **({"variants": VARIANTS,
                                                        "burst_s": BURST_S,
                                                        "burst_sd": BURST_SD}
                                                       if args.varied else {})})
    done = {x["record"] for x in doc["runs"]}
    for r in range(args.records):
        if r in done or args.summarise:
            continue
        doc["runs"].append(sim_record(r, args.likelihood, args.varied))
        print(json.dumps(doc["runs"][-1]), flush=True)
        doc["summary"] = sim_summary(doc["runs"])
        study_results.write(out, doc)
    doc["summary"] = sim_summary(doc["runs"])
    study_results.write(out, doc)
    print(json.dumps(doc["summary"], indent=1))


MODEL_OUT = RESULTS / "record_wander_model.json"
#: The model alone: wander sd over the windows' median sd, time scale in
#: spacings (the last: half the record), records per regime, windows per record.
REGIMES_TAU, REGIMES_ELL, MODEL_RECORDS, MODEL_WINDOWS = (0.0, 0.5, 4.0), (0.3, 5.0, 48.0), 200, 96


def model_regime(tau_rel, ell_rel, first):
    """The wander model alone on window estimates drawn from it (96 windows
    10 minutes apart, sds 0.5-2 times a common one): how often the record
    value's 95 % interval and one drawn window's interval hold the truth,
    and the record value's z standard deviation."""
    from bayescal.record import draw_wander, fit_wander
    held_mu = held_window = 0
    z = []
    for seed in range(first, first + MODEL_RECORDS):
        rng = np.random.default_rng(seed)
        t = np.arange(MODEL_WINDOWS) * 600.0
        s = rng.uniform(0.5, 2.0, MODEL_WINDOWS) * 0.1
        m = float(np.median(s))
        x = draw_wander(t, tau_rel * m, ell_rel * 600.0, rng) + s * rng.standard_normal(t.size)
        k = int(rng.integers(t.size))
        f = fit_wander(x, s, t)
        held_mu += f.mu["ci95"][0] <= 0.0 <= f.mu["ci95"][1]
        held_window += f.record[k, 0] <= 0.0 <= f.record[k, 1]
        z.append(f.mu["median"] / f.mu["sd"])
    band = [int(binom.ppf(0.005, MODEL_RECORDS, 0.95)), int(binom.ppf(0.995, MODEL_RECORDS, 0.95))]
    return {"tau_over_sd": tau_rel, "ell_over_spacing": ell_rel, "records": MODEL_RECORDS,
            "mu_holds": int(held_mu), "window_holds": int(held_window), "band99": band,
            "mu_z_sd": float(np.std(z))}


def model_main():
    """Every regime of :data:`REGIMES_TAU` x :data:`REGIMES_ELL`, stored,
    with the prior's default longest time scale and with
    :data:`SENSITIVITY_ELL_MAX`."""
    from bayescal.record import wander
    doc = {"command": "python validation/studies/record_wander.py --part model",
           "windows": MODEL_WINDOWS, "ell_max_spans": wander.ELL_MAX}
    for key, ell_max in (("regimes", wander.ELL_MAX), ("sensitivity", SENSITIVITY_ELL_MAX)):
        default, wander.ELL_MAX = wander.ELL_MAX, ell_max
        try:
            doc[key] = [model_regime(a, b, 10000 * (3 * i + j)) for i, a in enumerate(REGIMES_TAU)
                        for j, b in enumerate(REGIMES_ELL)]
        finally:
            wander.ELL_MAX = default
    doc["sensitivity_ell_max_spans"] = SENSITIVITY_ELL_MAX
    study_results.write(MODEL_OUT, doc)
    print(json.dumps(doc, indent=1))

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=["cowi", "sim", "model"], required=True)
    ap.add_argument("--summarise", action="store_true",
                    help="recompute the summary from the runs stored beside the output")
    ap.add_argument("--likelihood", choices=sorted(LIKELIHOODS), default="per-band",
                    help="each window's likelihood: per-band (bayescal fit's heavy-tailed "
                         "scale per band), or gaussian (bayescal windows' default: no per-band "
                         "scale, the record's inflation floor, a common factor learned)")
    ap.add_argument("--records", type=int, default=8, help="simulated records per setting")
    ap.add_argument("--varied", action="store_true",
                    help="part sim: the records cycle through VARIANTS (a steep ground "
                         "spectrum, noise in counts, two plane waves, noise bursts)")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    if args.part == "cowi":
        out = COWI_OUT if args.likelihood == "per-band" else COWI_OUT.with_name(
            f"record_wander_cowi_{args.likelihood}.json")
        if args.summarise:
            doc = study_results.read(out)
        else:
            doc = {"command": "python validation/studies/record_wander.py --part cowi"
                              + ("" if args.likelihood == "per-band"
                                 else f" --likelihood {args.likelihood}"),
                   "likelihood": args.likelihood, "runs": cowi_windows(args.likelihood)}
            study_results.write(out, doc)
        doc["summary"] = cowi_summary(doc["runs"], args.likelihood == "gaussian")
        study_results.write(out, doc)
        print(json.dumps(doc["summary"], indent=1))
    elif args.part == "model":
        model_main()
    else:
        sim_main(args)


if __name__ == "__main__":
    main()
