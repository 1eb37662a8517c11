"""Short windows on a real record: are ten-minute intervals as wide as the
data need, and no wider?

The ASL COWI pair (COWI LHN/LHE against AZI8 LH1/LH2, ../shared/data, band
1/8-1/3 Hz, the default fit: gains free, the reference's noise estimated)
is cut into consecutive 10-minute windows from 2010-08-23T22:00 to
2010-08-24T15:00, and each window is fitted as a user would (by default with
segments holding a transient in one sensor left out; ``--modes drop keep``
adds the fit with ``transients="keep"``). Each window's azimuths are set
beside the information limit of the segments the fit used: the per-bin
Fisher bound (``fisher_bound.py``, written apart from the fit's code). The
relative orientation does not change within the record, so per channel:

* ``scatter_over_bound``: the standard deviation of the windows' errors
  against the whole record's estimate, each in units of its window's bound
  (1 if the windows scatter as the bound says, more where the real data
  hold more than the model's noise);
* ``width_over_bound``: each window's 95 % width over its bound's 95 % width
  (at least 1: no interval narrower than the data allow; median at most 1.1
  times ``scatter_over_bound``: no wider than the scatter needs);
* the whole record's estimate inside the windows' 95 % intervals (99 %
  binomial band, :func:`hold_min`: at least 90 of 102);
* the repeatability ratio ``sqrt(chi2_red)`` of the medians against the
  reported sds (:mod:`bayescal.core.checks.repeatability`; 99 % band,
  :func:`ratio_band`: [0.82, 1.18] for 101 degrees of freedom).

    python validation/studies/short_windows.py --out validation/results/repeatability/short_windows.json
    python validation/studies/short_windows.py --every 3     # every third window (34 of 102)
    python validation/studies/short_windows.py --own-scale-prob 0.25 --scale-floor \
        --out validation/results/repeatability/short_windows_pooled.json   # the pooled scale
    python validation/studies/short_windows.py --per-channel --own-scale-prob 0 --scale-floor \
        --misfit-shape 2.5 --out validation/results/repeatability/short_windows_channel.json
        # a pooled scale per SUT channel (bayescal.core.model.channel_scale)
"""
from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import study_results                          # the sibling module, run as a script
import fisher_bound                           # the sibling module: the information limit

from scipy.stats import binom, chi2

from bayescal.core.checks.repeatability import reduced_chi_square, sd_from_ci68

ROOT = Path(__file__).resolve().parents[2]
COWI = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
BAND = (0.125, 0.3333333)
START, END = "2010-08-23T22:00:00", "2010-08-24T15:00:00"
SHOWN = ("2010-08-24T09:00:00", "2010-08-24T12:00:00")
#: Two-sided level of the bands the checks use.
BAND_LEVEL = 0.01


def ratio_band(n_windows, level=BAND_LEVEL):
    """The two-sided ``level`` band of ``sqrt(chi2_red)`` for ``n_windows``
    medians about a common value (``n_windows - 1`` degrees of freedom):
    ``sqrt(chi2.ppf(q, n - 1) / (n - 1))``."""
    dof = n_windows - 1
    return tuple(float(np.sqrt(chi2.ppf(q, dof) / dof)) for q in (level / 2, 1 - level / 2))


def hold_min(n_windows, level=BAND_LEVEL):
    """The fewest of ``n_windows`` 95 % intervals that hold a fixed value
    inside the two-sided ``level`` binomial band."""
    return int(binom.ppf(level / 2, n_windows, 0.95))


def channel_summary(ok, c, ref):
    """One channel's numbers over the fitted windows ``ok``."""
    med = np.array([o[c]["median"] for o in ok])
    sd = np.array([o[c]["sd68"] for o in ok])
    lo, hi = np.array([o[c]["ci95"] for o in ok]).T
    b_sd = np.array([o[c]["bound_sd"] for o in ok])
    b_w = np.array([o[c]["bound_width95"] for o in ok])
    z = (med - ref) / b_sd
    width_over = (hi - lo) / b_w
    _, ratio = reduced_chi_square(med, sd)
    scatter_over = float(np.std(z, ddof=1))
    held = int(np.sum((lo <= ref) & (ref <= hi)))
    r_lo, r_hi = ratio_band(len(ok))
    return {"windows": len(ok), "whole_record": ref,
            "median_width95": float(np.median(hi - lo)),
            "median_bound_width95": float(np.median(b_w)),
            "scatter_over_bound": scatter_over,
            "rms_error_over_bound": float(np.sqrt(np.mean(z ** 2))),
            "width_over_bound_median": float(np.median(width_over)),
            "width_over_bound_min": float(np.min(width_over)),
            "narrower_than_bound": int(np.sum(width_over < 1)),
            "median_width_over_scatter": float(np.median(width_over)) / scatter_over,
            "holds_whole_record": held, "holds_min": hold_min(len(ok)),
            "ratio_band": [r_lo, r_hi],
            "scatter_sd": float(np.std(med, ddof=1)), "median_sd68": float(np.median(sd)),
            "repeatability_ratio": ratio,
            "checks": {"median_width_at_most_1.1_scatter": bool(np.median(width_over)
                                                                 <= 1.1 * scatter_over),
                       "none_narrower_than_bound": bool(np.all(width_over >= 1)),
                       "holds_at_binomial_rate": held >= hold_min(len(ok)),
                       "ratio_in_99_band": bool(r_lo <= ratio <= r_hi)}}


def summarise(rows, whole, modes):
    """Per mode and channel: widths against bounds and scatter, the whole
    record inside the windows' intervals, the repeatability ratio; and the
    windows of :data:`SHOWN`."""
    summary = {}
    for mode in modes:
        ok = [r[mode] for r in rows if "LHN" in r.get(mode, {})]
        per = {c: channel_summary(ok, c, whole[mode][c]) for c in ("LHN", "LHE")}
        per["median_seconds"] = float(np.median([o["seconds"] for o in ok]))
        per["windows_with_drops"] = int(sum(o["dropped"] > 0 for o in ok))
        per["median_dropped"] = float(np.median([o["dropped"] for o in ok]))
        per["median_segments"] = float(np.median([o["segments"] + o["dropped"] for o in ok]))
        per["shown"] = {r["start"][:19]: {c: {"median": r[mode][c]["median"],
                                              "ci95": r[mode][c]["ci95"],
                                              "width95": r[mode][c]["ci95"][1]
                                              - r[mode][c]["ci95"][0],
                                              "bound_width95": r[mode][c]["bound_width95"]}
                                          for c in ("LHN", "LHE")}
                        for r in rows if r["start"][:19] in SHOWN and "LHN" in r.get(mode, {})}
        summary[mode] = per
    return summary


def posterior_draws(post):
    """The draws a likelihood's reweighting needs (``scale_candidates.py``):
    the azimuths (N, 2) of LHN and LHE, each draw's band energies ``q``
    (N, B), the bands' degrees of freedom ``k`` (B,) and weights (B,), and
    each SUT channel's share of them ``qc`` (N, B, 2) with its degrees of
    freedom ``kc`` (B, 2) (:mod:`bayescal.core.model.channel_scale`)."""
    from bayescal.core.model.channel_scale import channel_energy
    from bayescal.core.posterior.samples import sampled_azimuth_dip
    az, _ = sampled_azimuth_dip(post.vectors)
    cols = [post.channel_ids.index(f"US.COWI..{c}") for c in ("LHN", "LHE")]
    model = post.state.model
    q, k = model.band_energy(post.samples)
    qc, kc = channel_energy(model, post.samples)
    weight = getattr(model.noise, "weight", None)
    return {"az": az[:, cols], "q": q, "k": k, "qc": qc[..., cols], "kc": kc[:, cols],
            "weight": np.ones(k.size) if weight is None else np.asarray(weight, float)}


def fit_window(data, t0, t1, seed, mode, misfit_shape, draws=None):
    """One window's fit, its azimuths and the bound of the segments it used
    (``draws``: a dict given the window's :func:`posterior_draws`)."""
    from bayescal import calibrate
    from bayescal.io import flat_inventory
    sut, ref = data
    t = time.perf_counter()
    post = calibrate(sut=sut, sut_xml=flat_inventory(sut), ref=ref, ref_xml=flat_inventory(ref),
                     band=BAND, seed=seed, start=t0, end=t1, progress=False, diagnose=False,
                     transients=mode, misfit_shape=misfit_shape)
    seconds = time.perf_counter() - t
    if draws is not None:
        draws.update(posterior_draws(post))
    ch = post.summary()["channels"]
    used = post.state.spectra.segment_starts
    bound, _ = fisher_bound.window_bound(str(t0), str(t1), BAND, post.state.spectra.nperseg
                                         / post.state.spectra.fs, COWI, use=used)
    out = {"seconds": round(seconds, 2), "segments": int(len(used)),
           "dropped": post.meta.data_used.get("transients", {}).get("dropped", 0)}
    for c in ("LHN", "LHE"):
        az = ch[f"US.COWI..{c}"]["azimuth_deg"]
        out[c] = {"median": az["median"], "ci95": az["ci95"],
                  "sd68": float(sd_from_ci68(az["ci68"])),
                  "bound_sd": bound[c]["sd_deg"], "bound_width95": bound[c]["width95_deg"]}
    return out


def whole_record(data, t0, t1, modes, misfit_shape, draws=None):
    """The whole record's azimuths per mode (``draws``: a dict given the
    first mode's :func:`posterior_draws`)."""
    from bayescal import calibrate
    from bayescal.io import flat_inventory
    sut, ref = data
    whole = {}
    for mode in modes:
        post = calibrate(sut=sut, sut_xml=flat_inventory(sut), ref=ref, ref_xml=flat_inventory(ref),
                         band=BAND, start=t0, end=t1, progress=False, diagnose=False,
                         transients=mode, misfit_shape=misfit_shape)
        ch = post.summary()["channels"]
        whole[mode] = {c: ch[f"US.COWI..{c}"]["azimuth_deg"]["median"] for c in ("LHN", "LHE")}
        if draws is not None and mode == modes[0]:
            draws.update(posterior_draws(post))
    return whole


def _arguments(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "repeatability"
                                         / "short_windows.json"))
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--every", type=int, default=1, help="every n-th window only (evenly spaced)")
    ap.add_argument("--seed-offset", type=int, default=0,
                    help="window k's sampler seed is k plus this (0: k)")
    ap.add_argument("--modes", nargs="+", default=["drop"], choices=["drop", "keep"])
    ap.add_argument("--misfit-shape", type=float, default=None,
                    help="the fit's misfit-scale shape (inf: Gaussian); default: the fit's own")
    ap.add_argument("--own-scale-prob", type=float, default=None,
                    help="each band's prior probability of its own noise scale; default: the fit's")
    ap.add_argument("--scale-floor", action="store_true",
                    help="every noise scale at least 1 (misfit_scale.SCALE_FLOOR on)")
    ap.add_argument("--factor-floor", type=float, default=None,
                    help="the scale per band's least variance factor (misfit_scale.FACTOR_FLOOR; "
                         "0: the plain marginal); default: the fit's")
    ap.add_argument("--per-channel", action="store_true",
                    help="a noise scale per SUT channel (misfit_scale.PER_CHANNEL on)")
    ap.add_argument("--summarise", action="store_true",
                    help="recompute the summary of the windows stored beside --out")
    return ap.parse_args(argv)


def main(argv=None):
    args = _arguments(argv)
    if args.summarise:
        result = study_results.read(args.out)
        result["summary"] = summarise(result["runs"], result["whole_record"], result["modes"])
        study_results.write(args.out, result)
        print(json.dumps(result["summary"], indent=1))
        return
    from obspy import UTCDateTime
    from bayescal.core.model import misfit_scale
    from bayescal.io import read_waveforms
    warnings.simplefilter("ignore")
    if args.own_scale_prob is not None:
        misfit_scale.OWN_SCALE_PROB = args.own_scale_prob
    if args.scale_floor:
        misfit_scale.SCALE_FLOOR = True
    if args.factor_floor is not None:
        misfit_scale.FACTOR_FLOOR = args.factor_floor
    if args.per_channel:
        misfit_scale.PER_CHANNEL = True
    data = (read_waveforms(str(COWI / "C100823215422_COWI.LHx")),
            read_waveforms([str(COWI / "DT000110.LH1"), str(COWI / "DT000110.LH2")]))
    t0, t1 = UTCDateTime(START), UTCDateTime(END)
    whole = whole_record(data, t0, t1, args.modes, args.misfit_shape)
    print("whole record", whole, flush=True)
    starts = np.arange(t0.timestamp, t1.timestamp - 1, args.minutes * 60)
    rows = []
    for k in range(0, starts.size, args.every):
        s = starts[k]
        row = {"start": str(UTCDateTime(s))}
        for mode in args.modes:
            try:
                row[mode] = fit_window(data, UTCDateTime(s), UTCDateTime(s + args.minutes * 60),
                                       k + args.seed_offset, mode, args.misfit_shape)
            except Exception as exc:     # a window the pipeline refuses (gaps): recorded
                row[mode] = {"refused": f"{type(exc).__name__}: {exc}"}
        print(row["start"], {m: {c: (round(row[m][c]["median"], 2),
                                     round(row[m][c]["ci95"][1] - row[m][c]["ci95"][0], 2),
                                     round(row[m][c]["bound_width95"], 2))
                                 for c in ("LHN", "LHE")} if "LHN" in row[m] else row[m]
                             for m in args.modes}, flush=True)
        rows.append(row)
    shape = "default" if args.misfit_shape is None else args.misfit_shape
    command = " ".join(["python validation/studies/short_windows.py"]
                       + [shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)])
    result = {"command": command, "band_hz": list(BAND), "minutes": args.minutes,
              "every": args.every, "seed_offset": args.seed_offset, "modes": args.modes,
              "misfit_shape": shape,
              "own_scale_prob": misfit_scale.OWN_SCALE_PROB,
              "scale_floor": misfit_scale.SCALE_FLOOR, "factor_floor": misfit_scale.FACTOR_FLOOR,
              "per_channel": misfit_scale.PER_CHANNEL,
              "shape_a": misfit_scale.MISFIT_SHAPE if args.misfit_shape is None
              else args.misfit_shape,
              "whole_record": whole, "summary": summarise(rows, whole, args.modes), "runs": rows}
    study_results.write(args.out, result)
    print(json.dumps(result["summary"], indent=1))


if __name__ == "__main__":
    main()
