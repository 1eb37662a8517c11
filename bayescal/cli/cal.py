"""Calibrate an ordinary sensor's channel from a coil calibration run: the
input (coil drive, counts) recorded beside the output. Posterior over the
long-period pair (period, damping) and the generator gain (--fit lp), the
gain and the high-frequency poles and zeros of the nominal response that the
band reaches (--fit hf), or both (--fit all).

Example:
  bayescal cal --cal RUN.mseed --input-channel BC0 --output-channel BHZ \\
               --sut-xml SUT.xml --coil-constant 1e-9 --out DIR --fit lp
Writes DIR/cal.json (schema bayescal.cal/1), DIR/cal_samples.npz (the
samples and every array the report draws: `bayescal report DIR` redraws it),
DIR/sut_corrected.xml (the StationXML with the fitted values and their 68 %
errors) and the report (DIR/cal_report.pdf and PNG pages). With several
--output-channel, one sub-folder DIR/<SEED id>/ per channel and one
sut_corrected.xml holding them all.

--kind random (default): PRBS or any broadband drive, --fit lp/hf/all.
--kind step: one or more steps of the coil input; period, damping and gain
(--fit lp only). --kind sine: a single sine; the response's amplitude and
phase at its frequency against the nominal (no --fit; no sut_corrected.xml:
one frequency does not fix poles or a gain elsewhere).

Exit codes: 0 success; 2 bad input (one line naming the file and the problem;
nothing is written to DIR); 3 results written, but a sampler stopped at
--max-steps before meeting its convergence rule (a NOT CONVERGED line says
which; its intervals are provisional).
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from ..io.read import read_metadata
from .common import (add_paper_argument, add_sampling_argument, add_tolerance_arguments,
                     convergence_exit, priors_from, quiet_convergence_warnings, staging)

HELP = "calibration of a channel from a coil calibration run (random, step, sine; posterior)"
KINDS = ("random", "step", "sine")


def configure(parser):
    """Arguments of ``bayescal cal``."""
    parser.add_argument("--cal", required=True, metavar="RUN.mseed",
                        help="the calibration run: input and output channels")
    parser.add_argument("--input-channel", default="BC0",
                        help="channel code (or SEED id) of the coil input (default BC0)")
    parser.add_argument("--output-channel", action="append", required=True, metavar="CHA",
                        help="channel code (or SEED id) of an output to calibrate; repeat for "
                             "several")
    parser.add_argument("--sut-xml", required=True, metavar="SUT.xml",
                        help="StationXML (or RESP, or GSE2 .cal) with the outputs' nominal responses")
    parser.add_argument("--coil-constant", required=True, type=float, metavar="K",
                        help="equivalent ground acceleration per input count (m/s^2 per count)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--kind", default="random", choices=KINDS,
                        help="calibration signal (default random)")
    parser.add_argument("--fit", default=None, choices=("lp", "hf", "all"),
                        help="lp: period, damping, gain; hf: gain and the high-frequency "
                             "poles/zeros the band reaches; all: both (default lp; random "
                             "takes all three, step only lp, sine none)")
    parser.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"),
                        help="analysis band in Hz (default: lp 0.5/T0 to min(25/T0, fs/4), "
                             "raised when the record is short; hf 10/T0 to 0.4 fs)")
    add_tolerance_arguments(parser, "with --fit lp or all (random, step)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress display (the results are still printed, on stdout)")
    add_sampling_argument(parser)
    add_paper_argument(parser)


def load_runs(args):
    """Read the run and the StationXML; one single-output CalRun per channel."""
    from obspy import read

    from .. import coil

    if not args.coil_constant > 0:
        raise InputError(f"--coil-constant must be positive, not {args.coil_constant}")
    if args.band is not None and not 0 < args.band[0] < args.band[1]:
        raise InputError(f"--band {args.band[0]} {args.band[1]}: not a positive interval")
    if not os.path.isfile(args.cal):
        raise InputError(f"{args.cal}: no such file")
    try:
        st = read(args.cal)
    except Exception as exc:
        raise InputError(f"{args.cal}: not a readable waveform file ({exc})") from None
    inv = read_metadata(args.sut_xml, "SUT StationXML", stream=st)
    ids = ", ".join(tr.id for tr in st) or "none"
    if not any(args.input_channel in (tr.stats.channel, tr.id) for tr in st):
        raise InputError(f"{args.cal}: no input channel {args.input_channel} (--input-channel, a "
                         f"channel code or SEED id) among the file's channels: {ids}")
    runs = []
    for cha in args.output_channel:
        sel = [tr for tr in st if cha in (tr.stats.channel, tr.id)
               or args.input_channel in (tr.stats.channel, tr.id)]
        if not any(cha in (tr.stats.channel, tr.id) for tr in sel):
            raise InputError(f"{args.cal}: no output channel {cha} (--output-channel, a "
                             f"channel code or SEED id) among the file's channels: {ids}")
        if not coil.output_axis(cha[-3:]):
            raise InputError(f"{args.cal}: output channel {cha}: code must end in N/E/Z/1/2 "
                             "or U/V/W")
        sub = st.__class__(sel)
        runs.append(coil.read_run("U", sub, inv, args.input_channel, args.cal))
    return runs, inv


def write_outputs(fits, inventory, out, paper="a4"):
    """Write everything into a temporary folder, then move it into ``out``."""
    from ..coil.calxml import write_corrected_cal
    from ..io.result import write_json
    from ..report.cal import write_report_from_folder

    with staging(out) as tmp:
        summaries = []
        for fit in fits:
            folder = tmp if len(fits) == 1 else os.path.join(tmp, fit.channel)
            os.makedirs(folder, exist_ok=True)
            summary = fit.summary()
            write_json(os.path.join(folder, "cal.json"), summary)
            np.savez(os.path.join(folder, "cal_samples.npz"), **fit.report_arrays())
            write_report_from_folder(folder, paper=paper)
            summaries.append(summary)
        corrected = [f for f in fits if f.spec is not None]
        if corrected:
            write_corrected_cal(inventory, corrected, os.path.join(tmp, "sut_corrected.xml"))
    return summaries


def _fmt(entry):
    return f"{entry['median']:.6g} [{entry['ci95'][0]:.6g}, {entry['ci95'][1]:.6g}]"


def _print_summary(summary):
    from .fit import response_lines

    p = summary["parameters"]
    gain_units = summary.get("units", {}).get("gain", "").split(" (")[0]
    units = {"period_s": " s", "gain": f" {gain_units}",
             "response_amplitude": " counts/(m/s)", "response_phase_deg": " deg",
             "phase_difference_deg": " deg"}
    if "period_s" in p or "gain" in p:
        # a value the prior sets is named as such, never printed as a measurement
        lines = response_lines({"response": {k: p[k] for k in ("period_s", "damping", "gain",
                                                                 "damping_over_period") if k in p},
                                "nominal": dict(summary.get("nominal", {}),
                                                gain_units=gain_units)}, fmt=_fmt)
    else:
        lines = [f"{k} {_fmt(v)}{units.get(k, '')}" for k, v in p.items() if isinstance(v, dict)]
    print(f"{summary['channel']} ({summary['kind']}, fit {summary['fit']}), medians "
          "[95 % intervals]:")
    for line in lines:
        print(f"  {line}")
    for kind in ("hf_poles", "hf_zeros"):
        for e in p.get(kind, []):
            im = e["imag"].get("median", 0.0)
            print(f"  {kind[3:-1]} near {e['frequency_hz']:.4g} Hz: {e['real']['median']:.5g} "
                  f"+ {im:.5g}i rad/s (nominal {e['nominal'][0]:.5g} + {e['nominal'][1]:.5g}i)")
    ad, conv = summary["adequacy"], summary["convergence"]["converged"]
    print(f"  model check: mean standardised misfit {ad['misfit']:.3g} (about 1 when the model fits "
          f"the run; p {ad['p_value']:.3g}); sampler {'converged' if conv else 'NOT CONVERGED'}")


def run(args):
    """Entry point of ``bayescal cal``."""
    from ..coil.random import fit_random
    from ..coil.sine import fit_sine
    from ..coil.step import fit_step

    if args.kind == "sine" and args.fit is not None:
        raise InputError("--kind sine gives the response at the sine's frequency: --fit does "
                         "not apply")
    if args.kind != "random" and args.band is not None:
        raise InputError(f"--kind {args.kind} is fitted in the time domain: --band does not "
                         "apply")
    fit = args.fit or "lp"
    runs, inv = load_runs(args)
    band = tuple(args.band) if args.band else None
    fits = []
    for i, r in enumerate(runs):
        kw = dict(seed=args.seed + i, progress=not args.quiet, max_steps=args.max_steps)
        with quiet_convergence_warnings():
            if args.kind == "random":
                fits.append(fit_random(r, args.coil_constant, fit=fit, band=band,
                                       priors=priors_from(args), **kw))
            elif args.kind == "step":
                fits.append(fit_step(r, args.coil_constant, fit=fit, priors=priors_from(args),
                                     **kw))
            else:
                fits.append(fit_sine(r, args.coil_constant, **kw))
    summaries = write_outputs(fits, inv, args.out, paper=args.paper)
    for s in summaries:      # --quiet removes the progress display only
        _print_summary(s)
    from .common import say, written
    say(args, f"wrote {os.path.abspath(args.out)} ({', '.join(written(args.out))})")
    return convergence_exit([(f"the sampler of {s['channel']}", s["convergence"])
                             for s in summaries])
