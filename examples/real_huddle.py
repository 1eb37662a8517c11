"""Real-data validation 2: ObsPy's huddle test (STS-2 reference beside an
unknown sensor, vertical only, 200 Hz), fitting the unknown sensor's
response (gain, natural period, damping) with ``bayescal fit --fit-response``.

The data ship in ``../shared/data/real/obspy_relcal`` (see its README). The
reference's response comes from ``STS2_simp.cal`` (GSE2 poles and zeros, gain
1500, read with ObsPy); the unknown sensor has no metadata, so this script
writes a nominal two-pole StationXML for it (T0 = 120 s, h = 0.707,
1500 counts per m/s: a long-period broadband like the reference, because
ObsPy's ``rel_calib_stack`` shows its response flat down to 0.1 Hz). The
prior on the period is log-uniform within a factor 10 of that nominal value.

The fitted response is compared with ObsPy's ``rel_calib_stack`` over
0.3-3 Hz.

    python examples/real_huddle.py [--data DIR] [--out reports/real/huddle]
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from _real import parse_args, run_bayescal

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
BAND = (0.1, 2.0)
NOMINAL = {"period_s": 120.0, "damping": 0.707, "gain": 1500.0}
COMPARE_BAND = (0.3, 3.0)


def write_inputs(data, folder):
    """Write the reference and nominal SUT StationXML into ``folder``."""
    from bayescal import io

    os.makedirs(folder, exist_ok=True)
    ref = io.read_waveforms(data / "ref_STS2")
    sut = io.read_waveforms(data / "ref_unknown")
    poles, zeros, gain = io.read_gse2_paz(data / "STS2_simp.cal")
    # rel_calib_stack applies the GSE2 gain as a plain scale factor (A0 = 1)
    ref_xml, sut_xml = os.path.join(folder, "ref_STS2.xml"), os.path.join(folder, "unknown.xml")
    io.paz_inventory(ref, zeros=zeros, poles=poles, gain=gain, normalize=False).write(
        ref_xml, format="STATIONXML")
    io.two_pole_inventory(sut, **NOMINAL).write(sut_xml, format="STATIONXML")
    return ref_xml, sut_xml


def fitted_amplitude(result_dir, sut_xml, band=COMPARE_BAND, n=200):
    """Median over ``band`` of the fitted |H_unknown(f)| (counts per m/s),
    per posterior sample; returns (median, 2.5 %, 97.5 %)."""
    from bayescal.io.result import load_posterior
    from bayescal.io.read import read_metadata
    from bayescal.core.response import TwoPoleFamily, evaluate_velocity_response

    post = load_posterior(result_dir)
    resp = read_metadata(sut_xml)[0][0][0].response
    fam = TwoPoleFamily.from_response(resp)
    f = np.geomspace(band[0], band[1], n)
    nominal = np.abs(evaluate_velocity_response(resp, f))
    s = post.response[post.channel_ids[0]]
    amp = np.median(np.abs(fam.ratio(f, s[:, 0], s[:, 1], s[:, 2])) * nominal, axis=1)
    return float(np.median(amp)), float(np.percentile(amp, 2.5)), float(np.percentile(amp, 97.5))


def obspy_rel_calib(data, band=COMPARE_BAND, smooth=10):
    """Median amplitude over ``band`` of ObsPy's rel_calib_stack (20 s windows)."""
    import obspy
    from obspy.signal.calibration import rel_calib_stack

    f, amp, _ = rel_calib_stack(obspy.read(str(data / "ref_STS2")),
                                obspy.read(str(data / "ref_unknown")),
                                str(data / "STS2_simp.cal"), 20, smooth=smooth, save_data=False)
    m = (f >= band[0]) & (f <= band[1])
    return float(np.median(amp[m]))


def main(argv=None):
    a = parse_args(__doc__, DEFAULT_DATA, ROOT / "reports" / "real" / "huddle", argv)

    ref_xml, sut_xml = write_inputs(a.data, os.path.join(a.out, "inputs"))
    cmd = ["fit", "--ref", str(a.data / "ref_STS2"), "--ref-xml", ref_xml,
           "--sut", str(a.data / "ref_unknown"), "--sut-xml", sut_xml,
           "--out", os.path.join(a.out, "fit"), "--fit-response", "all",
           "--band", str(BAND[0]), str(BAND[1]), "--seed", str(a.seed), "--quiet", "--no-report"]
    elapsed = run_bayescal(cmd)
    res = json.load(open(os.path.join(a.out, "fit", "result.json")))
    (cid, ch), = res["channels"].items()
    print(f"{cid}: fitted in {elapsed:.1f} s (band {BAND[0]}-{BAND[1]} Hz)")
    from bayescal.cli.fit import response_lines
    for line in response_lines(ch):     # a value the prior sets is not printed as measured
        print(f"  {line}")
    med, lo, hi = fitted_amplitude(os.path.join(a.out, "fit"), sut_xml)
    print(f"  |H_unknown| median over {COMPARE_BAND[0]}-{COMPARE_BAND[1]} Hz: {med:.1f} "
          f"counts/(m/s), 95 % [{lo:.1f}, {hi:.1f}]")
    smooth, raw = obspy_rel_calib(a.data, smooth=10), obspy_rel_calib(a.data, smooth=0)
    print(f"  ObsPy rel_calib_stack, same band: {smooth:.1f} (smooth=10), {raw:.1f} "
          "(no smoothing)")
    with open(os.path.join(a.out, "comparison.json"), "w") as fh:   # what the docs quote
        json.dump({"band_hz": list(COMPARE_BAND), "units": "counts/(m/s)",
                   "bayescal_amplitude": {"median": med, "ci95": [lo, hi]},
                   "obspy_rel_calib_stack": {"smooth_10": smooth, "no_smoothing": raw}},
                  fh, indent=1)
    c = res["convergence"]
    print(f"  convergence: ESS min {c['ess_min']:.0f}, R-hat max {c['rhat_max']:.4f}")


if __name__ == "__main__":
    main()
