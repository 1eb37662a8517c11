"""The windows of a stored ``short_windows.py`` run that came out narrower
than their bound (or within ``--margin`` of it), refitted with other
sampler seeds: is a window under its bound the form of the noise scale, or
the sampler's chance (each interval's ends are quantiles of a few thousand
draws)?

    python validation/studies/reseeded_windows.py --run validation/results/repeatability/short_windows.json \
        --out validation/results/repeatability/reseeded_default.json
    python validation/studies/reseeded_windows.py --run validation/results/repeatability/short_windows_factor_floor.json \
        --misfit-shape 3 --factor-floor 1 --out validation/results/repeatability/reseeded_factor_floor.json
"""
from __future__ import annotations

import argparse
import shlex
import sys
import warnings

import numpy as np
import short_windows as sw                    # the sibling module, run as a script
import study_results


def narrow_windows(run, margin):
    """``(start, channel, width / bound)`` of the run's windows whose 95 %
    width is under ``1 + margin`` times their bound's."""
    out = []
    for row in run["runs"]:
        for c in ("LHN", "LHE"):
            d = row.get("drop", {}).get(c)
            if d is None:
                continue
            ratio = (d["ci95"][1] - d["ci95"][0]) / d["bound_width95"]
            if ratio < 1 + margin:
                out.append((row["start"][:19], c, ratio))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", required=True, help="a stored short_windows.py summary")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=8, help="seeds 1000, 1001, ... per window")
    ap.add_argument("--margin", type=float, default=0.0)
    ap.add_argument("--misfit-shape", type=float, default=None)
    ap.add_argument("--factor-floor", type=float, default=None)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    from obspy import UTCDateTime
    from bayescal.core.model import misfit_scale
    from bayescal.io import read_waveforms
    if args.factor_floor is not None:
        misfit_scale.FACTOR_FLOOR = args.factor_floor
    data = (read_waveforms(str(sw.COWI / "C100823215422_COWI.LHx")),
            read_waveforms([str(sw.COWI / "DT000110.LH1"), str(sw.COWI / "DT000110.LH2")]))
    windows = []
    for start, c, ratio in narrow_windows(study_results.read(args.run), args.margin):
        t0 = UTCDateTime(start)
        widths = []
        for seed in range(1000, 1000 + args.seeds):
            d = sw.fit_window(data, t0, t0 + 600.0, seed, "drop", args.misfit_shape)[c]
            widths.append((d["ci95"][1] - d["ci95"][0]) / d["bound_width95"])
        windows.append({"start": start, "channel": c, "in_run": ratio, "reseeded": widths,
                        "mean": float(np.mean(widths)), "sd": float(np.std(widths, ddof=1)),
                        "under_bound": int(np.sum(np.array(widths) < 1))})
        print(windows[-1], flush=True)
    study_results.write(args.out, {
        "command": " ".join(["python validation/studies/reseeded_windows.py"]
                            + [shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)]),
        "run": args.run, "seeds": args.seeds, "windows": windows})


if __name__ == "__main__":
    main()
