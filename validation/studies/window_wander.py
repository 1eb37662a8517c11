"""Why a window cannot see it: east's extra scatter on COWI, apart from the fit.

Written with numpy, scipy, ObsPy and ``fisher_bound.py``'s estimator only
(not bayescal's fit). The ASL COWI pair (LHN/LHE against AZI8 LH1/LH2,
1/8-1/3 Hz) is cut into the 102 ten-minute windows from 2010-08-23T22:00 to
2010-08-24T15:00 (64-s Hann segments, half overlap). A segment is left out
when the SUT's band power that the record's per-bin regression on the
reference does not explain exceeds ``--drop-factor`` times its median over
the 15 segments on either side (a transient in one sensor; a screen of its
own, not the fit's; ``--other-drop-factors`` repeat the study with other
factors). Per window and SUT horizontal:

* the weighted least-squares azimuth and its per-bin Fisher bound
  (:func:`fisher_bound.channel_bound`); the whole record's estimate is the
  same estimator over every window's kept segments;
* what the window's own data can see of its error beyond the bound: the kept
  segments split into ``--blocks`` consecutive blocks, each block's azimuth
  with its own bound (the window's noise weights), and
  ``T = sqrt(sum_j ((phi_j - phi_bar) / sd_j)^2 / (J - 1))`` (``phi_bar``
  their inverse-variance mean); and the burst index ``B``, the coefficient
  of variation over segments of the residual band power. Both are
  calibrated on ``--null`` simulated stationary windows (coloured ground,
  white plus red SUT noise, the same layout): there ``T`` and ``B`` have
  their null distributions and the estimate scatters as the bound says;
  with the azimuth moving within the window (``--power-wander``), the
  error a window can see, ``T`` rises with the scatter (its power).

Per channel: scatter of the normalised errors ``z = (phi_w - phi_rec) /
sd_w`` about the whole record; their autocorrelation at lags 1-6 against the
99 % band under independence, ``+-2.5758 / sqrt(n)``; a variance
decomposition (the window-level variance against the variance of one-hour
means: a white part averages down six-fold over an hour, a slow part does
not); ``T`` and ``B`` per channel (medians, Mann-Whitney test east against
north); the width and hold checks alone for any rule that widens a window
by a nondecreasing function ``h`` of ``T`` (the same for both channels):
north's limit (median width over bound at most 1.1 times its scatter over
bound) caps ``h`` at north's median ``T``; east's windows whose ``T`` is no
larger and whose error needs more than that cap are then missed (at least
the binomial floor, 90 of 102, must hold the whole record).
Last, the widenings fixed for every window (a factor on the bound, that
factor times ``max(1, T)``, an angle added in quadrature) that pass the
four checks of the windows, on this estimator and (``--fit-runs``) on the
fit's own window medians.

    python validation/studies/short_windows.py     # writes short_windows.runs.json, the fit's windows
    python validation/studies/window_wander.py --fit-runs validation/results/repeatability/short_windows.runs.json \
        --out validation/results/repeatability/window_wander.json
"""
from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter
from scipy.stats import binom, chi2, mannwhitneyu

import fisher_bound                           # the sibling module: the information limit

ROOT = Path(__file__).resolve().parents[2]
COWI = fisher_bound.COWI
BAND = (0.125, 0.3333333)
START, END = "2010-08-23T22:00:00", "2010-08-24T15:00:00"
CHANNELS = ("LHN", "LHE")
Z99 = 2.5758293035489004
NPERSEG, STEP, WINDOW = 64, 32, 600


# --- one window ----------------------------------------------------------------
def screen(xs, ys, factor, neighbours=15):
    """Boolean mask of the segments kept, over the record's segments ``xs``
    (K, 2, F) and ``ys`` (K, 2, F) in time order: the SUT's power left after
    the record's per-bin regression on the reference (what one sensor records
    and the other does not), summed over bins and channels, below ``factor``
    times the median over the ``neighbours`` segments on either side."""
    yy = np.einsum("kif,kjf->fij", ys.conj(), ys)
    xy = np.einsum("kcf,kjf->fcj", xs, ys.conj())
    coef = xy @ np.linalg.inv(yy)                                             # (F, 2, 2)
    left = np.sum(np.abs(xs - np.einsum("fcj,kjf->kcf", coef, ys)) ** 2, axis=(1, 2))
    typical = np.array([np.median(left[max(0, k - neighbours):k + neighbours + 1])
                        for k in range(left.size)])
    return left < factor * typical


def block_statistic(x, y, starts, noise, blocks):
    """``T`` of one channel: the kept segments ``x`` (K, F), ``y`` (K, 2, F)
    cut into ``blocks`` consecutive blocks, each block's weighted
    least-squares azimuth with its bound (weights ``1 / noise``)."""
    phi, sd = [], []
    for idx in np.array_split(np.arange(x.shape[0]), blocks):
        beta, yy = fisher_bound.least_squares(x[idx], y[idx], 1 / noise)
        r = fisher_bound.pair_correlation(NPERSEG, starts[idx], x.shape[1])
        cov, _ = fisher_bound.beta_covariance(yy, noise, r)
        phi.append(np.arctan2(beta[1], beta[0]))
        sd.append(fisher_bound.azimuth_sd(beta, cov))
    phi, w = np.array(phi), 1 / np.array(sd) ** 2
    mean = np.sum(w * phi) / np.sum(w)
    return float(np.sqrt(np.sum(w * (phi - mean) ** 2) / (blocks - 1)))


def channel_window(x, y, starts, blocks):
    """One channel's azimuth, bound, ``T`` and ``B`` in one window."""
    r = fisher_bound.pair_correlation(NPERSEG, starts, x.shape[1])
    b = fisher_bound.channel_bound(x, y, r)
    rad = np.radians(b["azimuth_deg"])
    beta = b["gain"] * np.array([np.cos(rad), np.sin(rad)])
    seg_power = np.mean(np.abs(x - np.einsum("i,kif->kf", beta, y)) ** 2, axis=1)
    return {"azimuth_deg": b["azimuth_deg"], "bound_sd_deg": b["sd_deg"],
            "T": block_statistic(x, y, starts, b["noise_power"], blocks),
            "B": float(np.std(seg_power) / np.mean(seg_power))}


def window(xs, ys, starts, blocks):
    """Per channel numbers of one window's kept segments ``xs`` (K, 2, F),
    ``ys`` (K, 2, F)."""
    return {name: channel_window(xs[:, c], ys, starts, blocks)
            for c, name in enumerate(CHANNELS)}


# --- stationary windows: the null --------------------------------------------
def _ar2(n, f0, q, rng):
    rad = np.exp(-np.pi * f0 / q)
    return lfilter([1.0], [1.0, -2 * rad * np.cos(2 * np.pi * f0), rad * rad],
                   rng.standard_normal(n + 500))[500:]


def null_windows(n_runs, args, phi_deg=3.2, wander_deg=0.0):
    """``T``, ``B`` and the normalised error of ``n_runs`` seeded simulated
    windows (seeds ``0 .. n_runs - 1``), stationary; with ``wander_deg`` the
    azimuth moves within the window, independently every 32 s by that sd
    (an error a window can see: the power of ``T``)."""
    f = np.fft.rfftfreq(NPERSEG)
    keep = (f >= BAND[0]) & (f <= BAND[1])
    rows = []
    for seed in range(n_runs):
        rng = np.random.default_rng(seed)
        ground = np.stack([_ar2(WINDOW, 0.18, 4.0, rng), _ar2(WINDOW, 0.18, 4.0, rng)])
        red = lfilter([1.0], [1.0, -0.9], rng.standard_normal(WINDOW + 500))[500:]
        noise = 0.6 * rng.standard_normal(WINDOW) + 0.15 * red
        phi = np.radians(phi_deg + wander_deg * np.repeat(rng.standard_normal(WINDOW // STEP + 1),
                                                          STEP)[:WINDOW])
        x = np.cos(phi) * ground[0] + np.sin(phi) * ground[1] + noise
        xs, starts = fisher_bound.segment_dfts(x[None], NPERSEG, STEP)
        ys, _ = fisher_bound.segment_dfts(ground, NPERSEG, STEP)
        w = channel_window(xs[:, 0, keep], ys[:, :, keep], starts, args.blocks)
        rows.append([w["T"], w["B"], (w["azimuth_deg"] - phi_deg) / w["bound_sd_deg"]])
    t, b, z = np.array(rows).T
    return {"n": n_runs, "seeds": [0, n_runs - 1], "wander_deg": wander_deg,
            "T_median": float(np.median(t)), "T_q90": float(np.quantile(t, 0.9)),
            "T2_mean": float(np.mean(t ** 2)), "B_median": float(np.median(b)),
            "scatter_over_bound": float(np.sqrt(np.mean(z ** 2))),
            "corr_abs_z_T": float(np.corrcoef(np.abs(z), t)[0, 1]),
            "band99_for_scatter": [1 - Z99 / np.sqrt(2 * n_runs), 1 + Z99 / np.sqrt(2 * n_runs)]}


# --- the record -----------------------------------------------------------------
def record(args):
    """Every window's numbers and the whole record's estimate."""
    sut, ref, fs = fisher_bound.read_window(args.data / "C100823215422_COWI.LHx",
                                            [args.data / "DT000110.LH1", args.data / "DT000110.LH2"],
                                            START, END, CHANNELS)
    keep = (lambda f: (f >= BAND[0]) & (f <= BAND[1]))(np.fft.rfftfreq(NPERSEG, 1 / fs))
    xs, ys, starts, which = [], [], [], []
    for i in range(sut.shape[1] // WINDOW):
        cut = slice(i * WINDOW, (i + 1) * WINDOW)
        x, s = fisher_bound.segment_dfts(sut[:, cut], NPERSEG, STEP)
        y, _ = fisher_bound.segment_dfts(ref[:, cut], NPERSEG, STEP)
        xs.append(x[..., keep]), ys.append(y[..., keep])
        starts.append(s + i * WINDOW), which.append(np.full(s.size, i))
    x, y, s, which = (np.concatenate(a) for a in (xs, ys, starts, which))
    use = screen(x, y, args.drop_factor)
    rows = []
    for i in range(which.max() + 1):
        k = use & (which == i)
        rows.append({"segments": int(np.sum(which == i)), "dropped": int(np.sum(~use & (which == i))),
                     **window(x[k], y[k], s[k], args.blocks)})
    r = fisher_bound.pair_correlation(NPERSEG, s[use], int(keep.sum()))
    whole = {c: fisher_bound.channel_bound(x[use][:, i], y[use], r)["azimuth_deg"]
             for i, c in enumerate(CHANNELS)}
    return rows, whole


def autocorrelation(z, lags):
    """Sample autocorrelation of ``z`` about its mean at ``lags``."""
    d = z - z.mean()
    return [float(np.sum(d[k:] * d[:-k]) / np.sum(d * d)) for k in lags]


def decomposition(z, per_hour):
    """Window-level variance of ``z`` about the whole record (0) split into a
    white part and a slow part from the variance of its hourly means:
    ``var(hour mean) = white / m + slow``, ``var(z) = white + slow``."""
    n = z.size // per_hour * per_hour
    v = float(np.mean(z[:n] ** 2))
    vh = float(np.mean(z[:n].reshape(-1, per_hour).mean(axis=1) ** 2))
    slow = (vh - v / per_hour) / (1 - 1 / per_hour)
    return {"variance": v, "hour_mean_variance": vh, "slow": slow, "white": v - slow,
            "slow_fraction": slow / v}


def rule_consequence(z_n, z_e, t_n, t_e, hold):
    """What a nondecreasing ``h(T)`` the same for both channels can do: the
    north limit caps ``h`` at north's median ``T``; the east windows with
    ``T`` at most that and an error needing more than the cap are missed."""
    cap = 1.1 * float(np.std(z_n, ddof=1))
    t_mid = float(np.sort(t_n)[len(t_n) // 2])        # the upper of the middle two
    need_e = np.abs(z_e) / fisher_bound.Z95
    forced = int(np.sum((t_e <= t_mid) & (need_e > cap)))
    order = np.sort(need_e)
    return {"north_limit_factor": cap, "north_median_T": t_mid,
            "east_forced_misses": forced, "east_allowed_misses": len(z_e) - hold,
            "east_held_at_most": len(z_e) - forced, "hold_min": hold,
            "east_least_constant_factor": float(order[hold - 1]),
            "north_least_constant_factor": float(np.sort(np.abs(z_n) / fisher_bound.Z95)[hold - 1]),
            "feasible": bool(forced <= len(z_e) - hold)}


def ratio(phi, sd):
    """Repeatability ratio of estimates ``phi`` with reported sds ``sd``:
    ``sqrt`` of the reduced chi-square about their weighted mean
    (``n - 1`` degrees of freedom)."""
    w = 1 / sd ** 2
    mean = np.sum(w * phi) / np.sum(w)
    return float(np.sqrt(np.sum(w * (phi - mean) ** 2) / (phi.size - 1)))


def passes(phi, sd, err, reported, hold, band):
    """The four checks of one channel whose windows report sds ``reported``
    (bound sds ``sd``, errors ``err`` about the whole record): median width
    over bound at most 1.1 times the scatter over bound, none under its
    bound, at least ``hold`` holding the whole record, the ratio in ``band``."""
    return bool(np.median(reported / sd) <= 1.1 * np.std(err / sd, ddof=1)
                and np.all(reported >= sd)
                and np.sum(np.abs(err) <= fisher_bound.Z95 * reported) >= hold
                and band[0] <= ratio(phi, reported) <= band[1])


def _span(values):
    return [float(values[0]), float(values[-1])] if values else None


def fixed_widenings(per, hold):
    """The widenings, each the same for every window, that pass the four
    checks: a factor ``c`` on each window's bound (1-3), the factor times
    ``max(1, T)`` (what the window's own blocks show), and an angle ``tau``
    (deg, 0-0.6) added in quadrature, ``sqrt(sd^2 + tau^2)``; per channel and
    common to both. ``per``: per channel (estimates, bound sds, errors, ``T``)."""
    n = len(per[0][0])
    band = [float(np.sqrt(chi2.ppf(q, n - 1) / (n - 1))) for q in (0.005, 0.995)]
    factors = np.round(np.arange(1.0, 3.0001, 0.01), 2)
    forms = {"factor": (factors, lambda sd, c, t: c * sd),
             "factor_times_T": (factors, lambda sd, c, t: c * np.maximum(1, t) * sd),
             "tau_deg": (np.round(np.arange(0.0, 0.6001, 0.005), 3),
                         lambda sd, v, t: np.sqrt(sd ** 2 + v ** 2))}
    out = {"ratio_band99": band}
    for name, (grid, widen) in forms.items():
        ok = np.array([[passes(phi, sd, err, widen(sd, v, t), hold, band)
                        for phi, sd, err, t in per] for v in grid])
        out[name] = {**{c: _span(grid[ok[:, i]].tolist()) for i, c in enumerate(CHANNELS)},
                     "both": _span(grid[ok.all(axis=1)].tolist())}
    return out


def _arrays(rows, whole, c):
    phi = np.array([r[c]["azimuth_deg"] for r in rows])
    sd = np.array([r[c]["bound_sd_deg"] for r in rows])
    return phi, sd, (phi - whole[c]) / sd


def channel(rows, whole, c):
    """One channel's scatter, autocorrelation, decomposition and ``T``, ``B``."""
    phi, sd, z = _arrays(rows, whole, c)
    t = np.array([r[c]["T"] for r in rows])
    b = np.array([r[c]["B"] for r in rows])
    hour_means = z[: z.size // 6 * 6].reshape(-1, 6).mean(axis=1)
    return {"whole_record_deg": whole[c], "median_bound_sd_deg": float(np.median(sd)),
            "scatter_over_bound": float(np.std(z, ddof=1)),
            "rms_over_bound": float(np.sqrt(np.mean(z ** 2))),
            "successive_difference_scatter": float(np.std(np.diff(z), ddof=1) / np.sqrt(2)),
            "autocorrelation": autocorrelation(z, range(1, 7)),
            "band99": Z99 / np.sqrt(z.size),
            "decomposition": decomposition(z, 6),
            "largest_hour_mean": float(np.max(np.abs(hour_means))),
            "T_median": float(np.median(t)), "T2_mean": float(np.mean(t ** 2)),
            "T_quartiles": np.quantile(t, [0.25, 0.75]).tolist(),
            "B_median": float(np.median(b)),
            "corr_abs_z_T": float(np.corrcoef(np.abs(z), t)[0, 1]),
            "corr_abs_z_bound": float(np.corrcoef(np.abs(z), sd)[0, 1]),
            "bound_sd_range_deg": [float(sd.min()), float(sd.max())],
            "z": z.tolist(), "T": t.tolist()}


def summarise(rows, whole, null, hold):
    """Per channel numbers, east against north, and the rule's consequence."""
    per = {c: channel(rows, whole, c) for c in CHANNELS}
    n, e = per["LHN"], per["LHE"]
    t_n, t_e = np.array(n.pop("T")), np.array(e.pop("T"))
    z_n, z_e = np.array(n.pop("z")), np.array(e.pop("z"))
    b_n = np.array([r["LHN"]["B"] for r in rows])
    b_e = np.array([r["LHE"]["B"] for r in rows])
    return {**per, "null": null,
            "east_vs_north": {"T_mannwhitney_p_east_greater":
                              float(mannwhitneyu(t_e, t_n, alternative="greater").pvalue),
                              "B_mannwhitney_p_east_greater":
                              float(mannwhitneyu(b_e, b_n, alternative="greater").pvalue)},
            "rule": rule_consequence(z_n, z_e, t_n, t_e, hold),
            "fixed_widening": fixed_widenings(
                [(phi, sd, phi - whole[c], np.array([r[c]["T"] for r in rows]))
                 for c in CHANNELS for phi, sd, _ in [_arrays(rows, whole, c)]], hold),
            "windows": len(rows), "median_dropped": float(np.median([r["dropped"] for r in rows])),
            "median_segments": float(np.median([r["segments"] for r in rows]))}


def brief(summary):
    """The main numbers of a summary (for the other screens)."""
    per = {c: {k: summary[c][k] for k in ("whole_record_deg", "scatter_over_bound", "T_median")}
           | {"lag1": summary[c]["autocorrelation"][0],
              "slow_fraction": summary[c]["decomposition"]["slow_fraction"]} for c in CHANNELS}
    return {**per, "median_dropped": summary["median_dropped"],
            "east_vs_north": summary["east_vs_north"],
            "east_least_constant_factor": summary["rule"]["east_least_constant_factor"],
            "north_limit_factor": summary["rule"]["north_limit_factor"],
            "fixed_widening": summary["fixed_widening"]}


def fit_windows(path, hold):
    """The same widenings on the fit's own window medians and their bounds
    (a ``short_windows.py`` per-run file, mode "drop"); ``T`` taken as 1."""
    doc = json.loads(Path(path).read_text())
    rows = [r["drop"] for r in doc["runs"] if "LHN" in r.get("drop", {})]
    whole = doc["whole_record"]["drop"]
    per, out = [], {"file": Path(path).name, "windows": len(rows)}
    for c in CHANNELS:
        phi = np.array([r[c]["median"] for r in rows])
        sd = np.array([r[c]["bound_sd"] for r in rows])
        z = (phi - whole[c]) / sd
        per.append((phi, sd, phi - whole[c], np.ones_like(phi)))
        out[c] = {"scatter_over_bound": float(np.std(z, ddof=1)),
                  "lag1": autocorrelation(z, [1])[0],
                  "corr_abs_z_bound": float(np.corrcoef(np.abs(z), sd)[0, 1])}
    widen = fixed_widenings(per, hold)
    out["fixed_widening"] = {k: widen[k] for k in ("factor", "tau_deg")}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "repeatability"
                                         / "window_wander.json"))
    ap.add_argument("--data", type=Path, default=COWI)
    ap.add_argument("--blocks", type=int, default=4)
    ap.add_argument("--drop-factor", type=float, default=2.0)
    ap.add_argument("--other-drop-factors", type=float, nargs="*", default=[1.5, 3.0],
                    help="screens also run, their main numbers stored")
    ap.add_argument("--fit-runs", type=Path, default=None,
                    help="a short_windows.py per-run file: the same widenings on the fit's medians")
    ap.add_argument("--power-wander", type=float, default=6.0,
                    help="sd (deg) of the simulated azimuth's moves every 32 s: T's power")
    ap.add_argument("--null", type=int, default=400, help="stationary simulated windows")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        sys.exit(f"data folder {args.data} not found (see ../shared/data/README.md)")
    t0 = time.time()
    rows, whole = record(args)
    hold = int(binom.ppf(0.005, len(rows), 0.95))
    null = null_windows(args.null, args)
    power = null_windows(args.null, args, wander_deg=args.power_wander)
    out = {"command": "python validation/studies/window_wander.py "
                      + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:])),
           "band_hz": list(BAND), "span": [START, END], "segment_s": NPERSEG,
           "blocks": args.blocks, "drop_factor": args.drop_factor, "hold_min": hold,
           "summary": summarise(rows, whole, null, hold), "power": power, "other_screens": {}}
    if args.fit_runs is not None:
        out["fit_windows"] = fit_windows(args.fit_runs, hold)
    for factor in args.other_drop_factors:
        args.drop_factor = factor
        out["other_screens"][str(factor)] = brief(summarise(*record(args), null, hold))
    out["seconds"] = round(time.time() - t0, 1)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out["summary"], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
