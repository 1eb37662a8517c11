"""ObsPy's huddle pair (an STS-2 and an unknown sensor, vertical): the SUT's
response relative to the reference's metadata under the headline model
(result.json's ``response_curve``) against ObsPy's ``rel_calib_stack``
result (``unknown.resp``, which is conj(H_sut / H_ref) * H_ref with H_ref
the STS-2's simplified response, ``STS2_simp.cal``): amplitude ratio and
phase difference of conj(R_fit) * H_STS2simp against the table at 30
log-spaced frequencies in 0.15-10 Hz (issue 40's proof: median
|ratio - 1| <= 2 %, max 5 %; median |phase difference| <= 0.03 rad, max
0.05). Needs the shared data (../shared/data/real/obspy_relcal); about a
minute per fit.

    python validation/studies/huddle_relative_response.py [--sut-xml flat] \
        [--bands 0.15 10 0.15 0.691] [--out validation/results/huddle/relative_response.json]

One fit per band (pairs of edges in ``--bands``); the summary (one row per
band) goes to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
OUT = ROOT / "validation" / "results" / "huddle" / "relative_response.json"


def compare(curve, cal, table, freqs):
    """(amplitude ratio - 1, phase difference in rad) of conj(R) * H_cal
    against ``table`` (frequency, amplitude, phase rows of ``unknown.resp``)
    at ``freqs``: R interpolated in log frequency from ``curve`` (one
    channel's ``response_curve`` entry and its grid ``curve_f``)."""
    entry, grid = curve
    x = np.log(freqs)
    amp = np.interp(x, np.log(grid), entry["amplitude"]["median"])
    ph = np.interp(x, np.log(grid), entry["phase_rad"]["median"])
    ours = np.conj(amp * np.exp(1j * ph)) * cal
    f, a, p = table.T
    theirs = np.interp(x, np.log(f), a) * np.exp(1j * np.interp(x, np.log(f), p))
    ratio = ours / theirs
    return np.abs(ratio) - 1.0, np.angle(ratio)


def one_band(d, sut_xml, band):
    """Fit the pair on ``band`` (Hz edges) and compare its response curve
    with ``unknown.resp``: the row of the study's table."""
    from bayescal.cli import main as cli
    from bayescal.io import read_gse2_paz
    from bayescal.core.response import transfer

    out = Path(tempfile.mkdtemp()) / "huddle"
    cli(["fit", "--ref", str(d / "ref_STS2"), "--ref-xml", str(d / "STS2_simp.cal"),
         "--sut", str(d / "ref_unknown"), "--sut-xml", sut_xml, "--out", str(out),
         "--no-report", "--quiet", "--band", *map(str, band)])
    result = json.loads((out / "result.json").read_text())
    curve = result["response_curve"]
    (entry,) = curve["channels"].values()
    poles, zeros, gain = read_gse2_paz(str(d / "STS2_simp.cal"))
    lo, hi = curve["freq_hz"][0], curve["freq_hz"][-1]
    freqs = np.geomspace(0.15, 10.0, 30)
    freqs = freqs[(freqs >= lo) & (freqs <= hi)]
    cal = gain * transfer(2j * np.pi * freqs, zeros, poles)
    amp, phase = compare((entry, np.asarray(curve["freq_hz"])), cal,
                         np.loadtxt(d / "unknown.resp"), freqs)
    return {"band_hz": list(band), "curve_band_hz": [lo, hi], "n_freqs": int(freqs.size),
            "headline": result["meta"]["headline"]["model"],
            "verdict": result.get("criticism", {}).get("verdict"),
            "effects": curve["effects"], "left_out": curve["left_out"],
            "amplitude_median": float(np.median(np.abs(amp))),
            "amplitude_max": float(np.max(np.abs(amp))),
            "phase_median_rad": float(np.median(np.abs(phase))),
            "phase_max_rad": float(np.max(np.abs(phase)))}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--sut-xml", default="flat")
    ap.add_argument("--bands", nargs="+", type=float, default=[0.15, 10.0, 0.15, 0.691])
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    if not a.data.is_dir():
        sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import study_results

    bands = list(zip(a.bands[0::2], a.bands[1::2]))
    table = []
    for band in bands:
        row = one_band(a.data, a.sut_xml, band)
        table.append(row)
        print(f"band {band[0]:g}-{band[1]:g} Hz: headline {row['headline']}, "
              f"effects {row['effects']}, left out {row['left_out']}; curve "
              f"{row['curve_band_hz'][0]:.3g}-{row['curve_band_hz'][1]:.3g} Hz, "
              f"{row['n_freqs']} frequencies")
        print(f"  amplitude |ratio - 1|: median {row['amplitude_median']:.4f}, "
              f"max {row['amplitude_max']:.4f}")
        print(f"  phase |difference| (rad): median {row['phase_median_rad']:.4f}, "
              f"max {row['phase_max_rad']:.4f}")
    command = " ".join(["python validation/studies/huddle_relative_response.py",
                        *(sys.argv[1:] if argv is None else argv)])
    study_results.write(a.out, {"command": command,
                                "sut_xml": a.sut_xml, "table": table})
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
