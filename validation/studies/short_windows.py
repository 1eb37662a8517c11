"""Short windows on a real record: do ten minutes keep what they say?

The ASL COWI pair (COWI LHN/LHE against AZI8 LH1/LH2, ../shared/data, band
1/8-1/3 Hz, the default fit: gains free, the reference's noise estimated)
is cut into consecutive 10-minute windows from 2010-08-23T22:00 to
2010-08-24T15:00, and each window is fitted as a user would, once with the
defaults (segments holding a transient in one sensor left out) and once with
``transients="keep"``. The relative orientation does not change within the
record, so:

* the scatter of the windows' azimuth medians against their reported
  standard deviations (68 % half-widths) gives ``sqrt(chi2_red)``, the factor
  by which the intervals are too narrow (above 1) or too wide (below 1)
  (:mod:`bayescal.core.repeatability`);
* each window's 95 % interval is compared with the whole record's estimate
  (the same fit over all 17 hours, in each mode) and with the width the data's
  coherence allows, ``2 x 1.96 x sqrt((1 - g2) / (2 n g2))`` rad, ``g2`` the
  squared multiple coherence of the channel with the reference averaged
  over the band and ``n`` the band's bins times segments used.

    python validation/studies/short_windows.py --out validation/results/repeatability/short_windows.json
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.core.checks.repeatability import reduced_chi_square, sd_from_ci68

ROOT = Path(__file__).resolve().parents[2]
COWI = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
BAND = (0.125, 0.3333333)
START, END = "2010-08-23T22:00:00", "2010-08-24T15:00:00"
MODES = ("drop", "keep")


def _coherence_width(post, channel):
    """The 95 % width (degrees) the band's coherence allows one channel."""
    sp = post.state.spectra
    i = sp.sut_ids.index(channel)
    g2 = float(np.mean(sp.multiple_coherence()[i]))
    n = float(sp.bins_per_band.sum() * sp.n_segments)
    return float(np.degrees(2 * 1.96 * np.sqrt((1 - g2) / (2 * n * g2)))), g2


def summarise(rows, whole):
    """Per mode and channel: widths, the whole record's estimate inside the
    windows' intervals, the repeatability ratio."""
    summary = {}
    for mode in MODES:
        ok = [r[mode] for r in rows if "LHN" in r[mode]]
        per = {}
        for c in ("LHN", "LHE"):
            med = np.array([o[c]["median"] for o in ok])
            sd = np.array([o[c]["sd68"] for o in ok])
            lo = np.array([o[c]["ci95"][0] for o in ok])
            hi = np.array([o[c]["ci95"][1] for o in ok])
            allowed = np.array([o[c]["coherence_width"] for o in ok])
            chi2, ratio = reduced_chi_square(med, sd)
            ref = whole[mode][c]
            per[c] = {"windows": len(ok), "median_width95": float(np.median(hi - lo)),
                      "width95_under_1.5": int(np.sum(hi - lo < 1.5)),
                      "width_over_coherence_width_median": float(np.median((hi - lo) / allowed)),
                      "whole_record": ref,
                      "holds_whole_record": int(np.sum((lo <= ref) & (ref <= hi))),
                      "scatter_sd": float(np.std(med, ddof=1)), "median_sd68": float(np.median(sd)),
                      "chi2_red": chi2, "ratio": ratio}
        per["median_seconds"] = float(np.median([o["seconds"] for o in ok]))
        per["windows_with_drops"] = int(sum(o["dropped"] > 0 for o in ok))
        summary[mode] = per
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "repeatability"
                                         / "short_windows.json"))
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--limit", type=int, default=None, help="first N windows only")
    ap.add_argument("--summarise", action="store_true",
                    help="recompute the summary of the windows stored in --out")
    args = ap.parse_args(argv)
    if args.summarise:
        result = json.loads(study_results.runs_path(args.out).read_text())
        result["summary"] = summarise(result["runs"], result["whole_record"])
        study_results.write(args.out, result)
        print(json.dumps(result["summary"], indent=1))
        return
    from obspy import UTCDateTime
    from bayescal import calibrate
    from bayescal.io import flat_inventory, read_waveforms
    warnings.simplefilter("ignore")
    sut = read_waveforms(str(COWI / "C100823215422_COWI.LHx"))
    ref = read_waveforms([str(COWI / "DT000110.LH1"), str(COWI / "DT000110.LH2")])
    t0, t1 = UTCDateTime(START), UTCDateTime(END)
    whole = {}
    for mode in MODES:
        post = calibrate(sut=sut, sut_xml=flat_inventory(sut), ref=ref, ref_xml=flat_inventory(ref),
                         band=BAND, start=t0, end=t1, progress=False, diagnose=False,
                         transients=mode)
        ch = post.summary()["channels"]
        whole[mode] = {c: ch[f"US.COWI..{c}"]["azimuth_deg"]["median"] for c in ("LHN", "LHE")}
    print("whole record", whole, flush=True)
    starts = np.arange(t0.timestamp, t1.timestamp - 1, args.minutes * 60)[:args.limit]
    rows = []
    for k, s in enumerate(starts):
        row = {"start": str(UTCDateTime(s))}
        for mode in MODES:
            t = time.perf_counter()
            try:
                post = calibrate(sut=sut, sut_xml=flat_inventory(sut), ref=ref,
                                 ref_xml=flat_inventory(ref), band=BAND, seed=k,
                                 start=UTCDateTime(s), end=UTCDateTime(s + args.minutes * 60),
                                 progress=False, diagnose=False, transients=mode)
            except Exception as exc:     # a window the pipeline refuses (gaps): recorded
                row[mode] = {"refused": f"{type(exc).__name__}: {exc}"}
                continue
            ch = post.summary()["channels"]
            out = {"seconds": round(time.perf_counter() - t, 2),
                   "dropped": post.meta.data_used.get("transients", {}).get("dropped", 0)}
            for cid in ("US.COWI..LHN", "US.COWI..LHE"):
                az = ch[cid]["azimuth_deg"]
                width, g2 = _coherence_width(post, cid)
                out[cid[-3:]] = {"median": az["median"], "ci95": az["ci95"],
                                 "sd68": float(sd_from_ci68(az["ci68"])),
                                 "coherence_width": width, "g2": g2}
            row[mode] = out
        print(row["start"], {m: (row[m].get("dropped"),
                                 {c: (round(row[m][c]["median"], 2),
                                      round(row[m][c]["ci95"][1] - row[m][c]["ci95"][0], 2))
                                  for c in ("LHN", "LHE")} if "LHN" in row[m] else row[m])
                             for m in ("drop", "keep")}, flush=True)
        rows.append(row)
    summary = summarise(rows, whole)
    result = {"command": "python validation/studies/short_windows.py", "band_hz": list(BAND),
              "minutes": args.minutes, "whole_record": whole, "summary": summary,
              "runs": rows}
    study_results.write(args.out, result)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
