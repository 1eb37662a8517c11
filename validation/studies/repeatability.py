"""Repeatability on real recordings: do the reported intervals match the
scatter between time windows of one record?

Each shared real recording (../shared/data, see its README) is split into
windows; each window is fitted with :func:`bayescal.calibrate` as a user
would (fixed band, ``progress=False``, no report); for every quantity
(azimuth of a horizontal, gain where fitted) the scatter of the window
medians is compared with each window's 68 % interval by the reduced
chi-square (:mod:`bayescal.core.checks.repeatability`). Relative orientation and
gain do not change within a record, so ``sqrt(chi2_red)`` is the factor by
which the intervals are too narrow (above 1) or too wide (below 1). Goal:
median ratio at most 1.3, none above 2.

Recordings: the ASL COWI pair (COWI LHN/LHE against AZI8 LH1/LH2, 1/8-1/3 Hz,
azimuths, 6 windows of 170 min), the ObsPy huddle pair (unknown sensor
against the STS-2, 0.1-2 Hz, gain, 6 windows of 10 min) and the II.XPFO
verticals (each pair among 00, 10, 60, the first as reference, 0.1-1 Hz,
gain, 6 windows of 20 min).

    python validation/studies/repeatability.py                      # the default likelihood
    python validation/studies/repeatability.py --misfit-shape inf   # the Gaussian likelihood

Writes validation/results/repeatability/table.json (or ``--out``) and prints a markdown
table.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from bayescal.core.orientation.geometry import unwrap_azimuths
from bayescal.core.checks.repeatability import reduced_chi_square, sd_from_ci68

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real"


def _windows(start, end, n):
    from obspy import UTCDateTime
    t = np.linspace(UTCDateTime(start).timestamp, UTCDateTime(end).timestamp, n + 1)
    return [(UTCDateTime(a), UTCDateTime(b)) for a, b in zip(t[:-1], t[1:])]


def cowi(data):
    """(label, sut, sut_inv, ref, ref_inv, band, fit_response, windows)."""
    from bayescal.io import flat_inventory, read_waveforms
    d = data / "asl_cowi_azimuth"
    sut = read_waveforms(str(d / "C100823215422_COWI.LHx"))
    ref = read_waveforms([str(d / "DT000110.LH1"), str(d / "DT000110.LH2")])
    yield ("COWI vs AZI8", sut, flat_inventory(sut), ref, flat_inventory(ref), (0.125, 0.3333333),
           "none", _windows("2010-08-23T22:00:00", "2010-08-24T15:00:00", 6))


def huddle(data):
    from bayescal import io
    d = data / "obspy_relcal"
    ref = io.read_waveforms(str(d / "ref_STS2"))
    sut = io.read_waveforms(str(d / "ref_unknown"))
    poles, zeros, gain = io.read_gse2_paz(str(d / "STS2_simp.cal"))
    ref_inv = io.paz_inventory(ref, zeros=zeros, poles=poles, gain=gain, normalize=False)
    sut_inv = io.two_pole_inventory(sut, period_s=120.0, damping=0.707, gain=1500.0)
    yield ("huddle (ObsPy)", sut, sut_inv, ref, ref_inv, (0.1, 2.0), "gain",
           _windows("2011-02-15T10:21:00", "2011-02-15T11:21:00", 6))


def xpfo(data):
    from bayescal.io import paz_inventory, read_waveforms
    from bayescal.simulate.selfnoise import DIGITIZER, STS1, T240
    d = data / "xpfo_selfnoise"
    sensors = {}
    for loc, fname, s in (("00", "bhz00_2hrs_new.seed", STS1), ("10", "bhz10_2hrs_new.seed", T240),
                          ("60", "bhz60_2hrs_new.seed", STS1)):
        st = read_waveforms(str(d / fname))
        sensors[loc] = (st, paz_inventory(st, zeros=s["zeros"], poles=s["poles"],
                                          gain=s["generator"] * DIGITIZER, norm_freq=1.0))
    windows = _windows("2015-04-10T00:00:30", "2015-04-10T01:59:30", 6)
    for r, u in (("00", "10"), ("00", "60"), ("10", "60")):
        yield (f"XPFO {u} vs {r}", *sensors[u], *sensors[r], (0.1, 1.0), "gain", windows)


def quantities(post):
    """Per quantity name: (median, sd) of one window's fit."""
    out = {}
    s = post.summary()["channels"]
    for cid, e in s.items():
        short = cid.split(".")[-1]
        az = e.get("azimuth_deg", {})
        if "ci68" in az and not az.get("undefined"):
            out[f"{short} azimuth"] = (az["median"], float(sd_from_ci68(az["ci68"])))
        g = e.get("response", {}).get("gain", {})
        if "ci68" in g and not g.get("set_by_prior"):
            out[f"{short} gain"] = (g["median"], float(sd_from_ci68(g["ci68"])))
    return out


def run(recordings, misfit_shape, log=print):
    from bayescal import calibrate
    rows = []
    for label, sut, sut_inv, ref, ref_inv, band, free, windows in recordings:
        per = {}
        for k, (t0, t1) in enumerate(windows):
            t = time.perf_counter()
            post = calibrate(sut=sut, sut_xml=sut_inv, ref=ref, ref_xml=ref_inv, band=band, fit_response=free, seed=k,
                             start=t0, end=t1, progress=False, misfit_shape=misfit_shape)
            q = quantities(post)
            ok = post.summary()["adequacy"].get("ok")
            log(f"  {label} window {k + 1}/{len(windows)}: {time.perf_counter() - t:.1f} s, "
                f"adequacy ok={ok}, " + ", ".join(f"{n} {m:.5g} +- {s:.2g}"
                                                  for n, (m, s) in q.items()))
            for name, v in q.items():
                per.setdefault(name, []).append(v)
        for name, vals in per.items():
            m, sd = np.array(vals).T
            if name.endswith("azimuth"):
                m = unwrap_azimuths(m)
            chi2, ratio = reduced_chi_square(m, sd)
            rows.append({"recording": label, "quantity": name, "band_hz": list(band),
                         "windows": len(m), "medians": m.tolist(), "sd68": sd.tolist(),
                         "scatter_sd": float(np.std(m, ddof=1)), "median_sd68": float(np.median(sd)),
                         "chi2_red": chi2, "ratio": ratio})
    return rows


def markdown(rows):
    lines = ["| recording | quantity | windows | scatter of medians (sd) | median reported sd "
             "(68 %) | chi2_red | ratio |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['recording']} | {r['quantity']} | {r['windows']} | "
                     f"{r['scatter_sd']:.3g} | {r['median_sd68']:.3g} | {r['chi2_red']:.2f} | "
                     f"{r['ratio']:.2f} |")
    ratios = [r["ratio"] for r in rows]
    lines.append(f"\nmedian ratio {np.median(ratios):.2f} (goal <= 1.3), largest "
                 f"{np.max(ratios):.2f} (goal <= 2)")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--misfit-shape", type=float, default=None,
                    help="shape a of the per-band noise-scale prior (inf: Gaussian); "
                         "default: the fit's default")
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "repeatability" / "table.json"))
    a = ap.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    import warnings
    warnings.simplefilter("ignore")
    t0 = time.perf_counter()
    recordings = [r for gen in (cowi, huddle, xpfo) for r in gen(a.data)]
    rows = run(recordings, a.misfit_shape)
    from bayescal.core.model.misfit_scale import MISFIT_SHAPE
    shape = MISFIT_SHAPE if a.misfit_shape is None else a.misfit_shape
    ratios = [r["ratio"] for r in rows]
    out = {"misfit_shape": None if not np.isfinite(shape) else shape,
           "command": "python validation/studies/repeatability.py"
                      + ("" if a.misfit_shape is None else f" --misfit-shape {a.misfit_shape:g}"),
           "median_ratio": float(np.median(ratios)), "max_ratio": float(np.max(ratios)),
           "seconds": time.perf_counter() - t0, "rows": rows}
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)
    print(markdown(rows))
    print(f"({out['seconds']:.0f} s; written {a.out})")


if __name__ == "__main__":
    main()
