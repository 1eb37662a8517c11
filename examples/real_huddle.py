"""Real-data validation 2: ObsPy's huddle test (STS-2 reference beside an
unknown sensor, vertical only, 200 Hz), fitting the unknown sensor's
response (gain, natural period, damping) with ``bayescal fit --fit-response``.

The data ship in ``../shared/data/real/obspy_relcal`` (see its README). The
reference's response comes from ``STS2_simp.cal`` (GSE2 poles and zeros, gain
1500, read with ObsPy); the unknown sensor has no metadata, so this script
writes a nominal two-pole StationXML for it (T0 = 120 s, h = 0.707,
1500 counts per m/s: a long-period broadband like the reference, because
ObsPy's ``rel_calib_stack`` shows its response flat down to 0.1 Hz). The
priors on period and damping are the sensor's default: log-normal around
those nominal values with 5 % relative standard deviation
(``--period-tolerance``, ``--damping-tolerance``).

The fitted response is compared with ObsPy's ``rel_calib_stack`` over
0.3-3 Hz. A second fit, on the default band with the default options and
the SUT's metadata both nominal and ``flat``, compares the SUT's response
relative to the reference's metadata as the criticism's improved model
sees it (:func:`relative_comparison`) with ObsPy's ``unknown.resp``.

``OUT/comparison.json`` holds what the docs quote: the amplitudes over
0.3-3 Hz, the fit's model check and verdict, and per default-band fit the
comparison with ``unknown.resp``, the effects named and their sizes, and
the criticism's work.

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


#: Where the relative response is compared with ``unknown.resp`` (Hz).
RELATIVE_FREQS = np.geomspace(0.15, 10.0, 30)


def obspy_curve(data):
    """``(freqs, unknown.resp as complex, gg)`` on the file's grid: ObsPy's
    ``rel_calib_stack`` result (20 s windows at 200 Hz, ``smooth=10``) and
    the STS-2's simplified response as ObsPy evaluates it
    (``paz_to_freq_resp`` of ``STS2_simp.cal``)."""
    from obspy.io.gse2.paz import read_paz
    from obspy.signal.invsim import paz_to_freq_resp

    f, amp, phase = np.loadtxt(data / "unknown.resp").T
    poles, zeros, gain = read_paz(str(data / "STS2_simp.cal"))
    gg, fr = paz_to_freq_resp(poles, zeros, gain, 1.0 / 200.0, 4096, freq=True)
    if not np.allclose(fr[1:], f):
        raise ValueError("unknown.resp is not on rel_calib_stack's 4096-point grid at 200 Hz")
    return f, amp * np.exp(1j * phase), gg[1:]


def fitted_ratio(state, data, ref_xml, sut_xml, freqs, draws=400):
    """The SUT's response over the reference's metadata under the model of
    ``state`` (counts over counts), posterior median of its real and
    imaginary parts, at ``freqs``: :func:`bayescal.criticism.relative_response`
    times the SUT's metadata response over the reference's."""
    import obspy

    from bayescal.core.response import evaluate_velocity_response
    from bayescal.criticism import relative_response
    from bayescal.io import load_inventory
    ref = obspy.read(str(data / "ref_STS2"))
    sut = obspy.read(str(data / "ref_unknown"))
    h_ref = evaluate_velocity_response(load_inventory(ref_xml, ref, "reference")[0][0][0].response,
                                       freqs)
    h_sut = evaluate_velocity_response(load_inventory(sut_xml, sut, "SUT")[0][0][0].response,
                                       freqs)
    rel = relative_response(state, freqs, draws=draws)[:, 0]
    return (np.median(rel.real, axis=0) + 1j * np.median(rel.imag, axis=0)) * h_sut / h_ref


def relative_comparison(state, data, ref_xml, sut_xml):
    """``conj(R_fit) * gg`` against ObsPy's ``unknown.resp`` at
    :data:`RELATIVE_FREQS`: ``{"smoothed": (amplitude median, max, phase
    median, max), "raw": (...)}`` of ``| |ratio| - 1 |`` and ``|phase
    difference|`` (rad). ``unknown.resp`` is ``conj(H_sut / H_ref) * gg``
    (mlab's cross-spectrum convention) with its real and imaginary parts
    smoothed by Konno-Ohmachi's window (bandwidth 10, normalised; it scales
    a constant by 0.980-0.984 on the file's grid), so ``smoothed`` passes the
    fit's curve through the same smoothing on the file's grid (like for
    like) and ``raw`` compares it unsmoothed."""
    from obspy.signal.konnoohmachismoothing import konno_ohmachi_smoothing

    f, obs, gg = obspy_curve(data)
    curve = np.conj(fitted_ratio(state, data, ref_xml, sut_xml, f)) * gg
    sm = konno_ohmachi_smoothing(np.vstack([curve.real, curve.imag]), f, bandwidth=10, count=1,
                                 max_memory_usage=1024, normalize=True)
    idx = [int(np.argmin(np.abs(f - x))) for x in RELATIVE_FREQS]
    out = {}
    for name, c in (("smoothed", sm[0] + 1j * sm[1]), ("raw", curve)):
        r = c[idx] / obs[idx]
        amp, ph = np.abs(np.abs(r) - 1), np.abs(np.angle(r))
        out[name] = (float(np.median(amp)), float(amp.max()), float(np.median(ph)),
                     float(ph.max()))
    return out


def improved_state(result):
    """The criticism's improved model's live state (the headline's when it
    heads the result), or None."""
    if (result.meta.headline or {}).get("model") == "improved":
        return result.state
    return None if result.improved is None else result.improved.state


def default_band_fit(data, ref_xml, sut_xml, seed=0):
    """``bayescal.calibrate_files`` with the default options (band chosen
    from the data, gains fitted, the criticism on)."""
    import warnings

    from bayescal.pair.workflow import calibrate_files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return calibrate_files(ref=str(data / "ref_STS2"), ref_xml=ref_xml,
                               sut=str(data / "ref_unknown"), sut_xml=sut_xml, progress=False,
                               seed=seed)


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
    c = res["convergence"]
    print(f"  convergence: ESS min {c['ess_min']:.0f}, R-hat max {c['rhat_max']:.4f}")
    stored = {"band_hz": list(COMPARE_BAND), "units": "counts/(m/s)",
              "bayescal_amplitude": {"median": med, "ci95": [lo, hi]},
              "obspy_rel_calib_stack": {"smooth_10": smooth, "no_smoothing": raw},
              "fit": {"adequacy_ok": res["adequacy"]["ok"],
                      "worst": res["adequacy"].get("worst"),
                      "verdict": (res.get("criticism") or {}).get("verdict")},
              "default_band": {}}
    for meta in (sut_xml, "flat"):
        name = os.path.basename(meta)
        stored["default_band"][name] = default_band_comparison(a, ref_xml, meta)
    with open(os.path.join(a.out, "comparison.json"), "w") as fh:   # what the docs quote
        json.dump(stored, fh, indent=1)


def default_band_comparison(a, ref_xml, meta):
    """Fit with the default band and options and ``meta`` as the SUT's
    metadata; print and return the comparison of its improved model's
    relative response with ``unknown.resp`` and its criticism's findings."""
    fit = default_band_fit(a.data, ref_xml, meta, a.seed)
    state, name = improved_state(fit), os.path.basename(meta)
    criticism = fit.criticism or {}
    out = {"band_hz": list(fit.meta.band_hz), "verdict": criticism.get("verdict"),
           "effects": {e["name"]: e.get("size", {}) for e in criticism.get("effects", [])},
           "unexplained": criticism.get("unexplained"), "budget": criticism.get("budget"),
           "seconds": criticism.get("seconds")}
    if state is None:
        print(f"default band, SUT metadata {name}: no improved model")
        return out
    cmp = relative_comparison(state, a.data, ref_xml, meta)
    out["relative_response"] = dict(zip(("amplitude_median", "amplitude_max", "phase_median_rad",
                                         "phase_max_rad"), cmp["smoothed"]))
    print(f"default band, SUT metadata {name}: effects "
          f"{', '.join(e.name for e in state.model.effects)}; relative response against "
          "unknown.resp, 0.15-10 Hz: amplitude median {:.4f} max {:.4f}, phase median {:.4f} "
          "max {:.4f} rad (smoothed like the file)".format(*cmp["smoothed"]))
    return out


if __name__ == "__main__":
    main()
