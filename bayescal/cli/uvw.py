"""Calibrate a symmetric triaxial sensor (STS-2, Trillium...) from coil-by-coil
calibration runs: one file per run, each with one element's coil driven.

Each --cal file holds the calibration input channel (counts) and the sensor's
outputs (X, Y, Z as channels 1/2/Z or N/E/Z; or U, V, W in UVW mode). The
result is a posterior over each element's natural period, damping and gain,
the XYZ responses M^T diag(k) M they imply (with credible bands) and the
largest cross-talk between X, Y and Z over the band. By default every
recorded output is used and each element is also fitted from Z alone (the
classic Z-only procedure); the two must agree, and a disagreement is reported as
evidence against the geometry.

Example:
  bayescal uvw --cal U=cal_U.mseed --cal V=cal_V.mseed --cal W=cal_W.mseed \\
               --input-channel BC0 --coil-constant 1e-9 --sensor sts2 \\
               --sut-xml sut.xml --out out/
Writes out/uvw.json (schema bayescal.uvw/1), out/uvw_samples.npz (the
samples every interval of uvw.json is taken from, and the bands the report
draws: `bayescal report out/` redraws it) and the report
(out/uvw_report.pdf and PNG pages).

Everyday use, no calibration: rotate recorded X, Y, Z to the element axes
U, V, W (or U, V, W back to X, Y, Z) to find a noisy or failed element:
  bayescal uvw --rotate rec.mseed --sensor sts2 --out out/
writes out/rec_uvw.mseed (or out/rec_xyz.mseed).

Exit codes: 0 success; 2 bad input (one line naming the file and the problem;
nothing is written to DIR); 3 results written, but a sampler stopped at
--max-steps before meeting its convergence rule (a NOT CONVERGED line says
which; its intervals are provisional).
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from ..atomic import atomic_path
from ..io.read import read_metadata
from .common import (add_paper_argument, add_sampling_argument, add_tolerance_arguments,
                     convergence_exit, priors_from, quiet_convergence_warnings, staging)

HELP = "UVW (STS-2, Trillium) calibration from coil-by-coil runs"


def configure(parser):
    """Arguments of ``bayescal uvw``."""
    parser.add_argument("--cal", action="append", metavar="ELEMENT=FILE",
                        help="calibration run of one element (U, V or W), miniSEED; repeat "
                             "for each element")
    parser.add_argument("--input-channel", default="BC0",
                        help="channel code (or SEED id) of the calibration input (default BC0)")
    parser.add_argument("--coil-constant", type=float, metavar="C",
                        help="equivalent ground acceleration per input count (m/s^2 per "
                             "count); without it gains are reported relative to each other")
    parser.add_argument("--sensor", default="sts2", choices=["sts2", "trillium"],
                        help="built-in UVW geometry (default sts2)")
    parser.add_argument("--matrix", metavar="FILE",
                        help="UVW matrix file (3 rows U, V, W of 3 numbers X, Y, Z), or "
                             "'identity' for an ordinary XYZ sensor (runs U=X, V=Y, W=Z; "
                             "--cal X=... etc. also accepted); overrides --sensor")
    parser.add_argument("--rotate", metavar="FILE",
                        help="only rotate FILE's X, Y, Z channels to U, V, W (or back) and "
                             "write it to DIR; no calibration")
    parser.add_argument("--sut-xml", metavar="SUT.xml",
                        help="StationXML (or RESP, or GSE2 .cal) with the nominal responses of the outputs")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--z-only", action="store_true",
                        help="use only the Z output of each run (the classic Z-only procedure)")
    parser.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"),
                        help="analysis band in Hz (default 0.5/T0 to min(25/T0, fs/4), the lower edge "
                             "raised when the record is short)")
    add_tolerance_arguments(parser, "for each element")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress display (the results are still printed, on stdout)")
    add_sampling_argument(parser)
    add_paper_argument(parser)


def _parse_cal(items, identity=False):
    runs = {}
    for item in items:
        name, sep, path = item.partition("=")
        name = name.strip().upper()
        if identity and name in ("X", "Y", "Z"):
            name = "UVW"["XYZ".index(name)]
        if not sep or name not in ("U", "V", "W") or not path:
            raise InputError(f"--cal {item!r}: expected ELEMENT=FILE with ELEMENT one of U, V, W")
        if name in runs:
            raise InputError(f"--cal: element {name} given twice ({runs[name]}, {path})")
        if not os.path.isfile(path):
            raise InputError(f"{path}: no such file")
        runs[name] = path
    missing = [e for e in ("U", "V", "W") if e not in runs]
    if missing:
        raise InputError(f"--cal: no run for element(s) {', '.join(missing)}")
    return runs


def load_inputs(args):
    """Read and check every input file; returns ``(runs, matrix, source)``."""
    from obspy import Stream, read

    from .. import coil

    identity = (args.matrix or "").lower() == "identity"
    paths = _parse_cal(args.cal, identity)
    if args.coil_constant is not None and not args.coil_constant > 0:
        raise InputError(f"--coil-constant must be positive, not {args.coil_constant}")
    if args.band is not None and not 0 < args.band[0] < args.band[1]:
        raise InputError(f"--band {args.band[0]} {args.band[1]}: not a positive interval")
    if identity:
        m, source = np.eye(3), "--matrix identity (ordinary XYZ sensor: U=X, V=Y, W=Z)"
    elif args.matrix:
        m, source = coil.load_matrix(args.matrix), f"--matrix {args.matrix}"
    else:
        m, source = coil.sensor_matrix(args.sensor)
    streams = {}
    for element, path in paths.items():
        try:
            streams[element] = read(path)
        except Exception as exc:
            raise InputError(f"{path}: not a readable waveform file ({exc})") from None
    inv = read_metadata(args.sut_xml, "SUT StationXML",
                        stream=sum(streams.values(), Stream()))
    runs = {}
    for element, path in paths.items():
        st = streams[element]
        runs[element] = coil.read_run(element, st, inv, args.input_channel, path)
    return runs, m, source


def write_outputs(result, out, quiet=True, paper="a4"):
    """Write ``uvw.json``, ``uvw_samples.npz`` and the report into ``out``:
    everything goes to a temporary folder first and is moved in at the end,
    so a failure leaves nothing half-written."""
    from ..coil.uvw import report_arrays
    from ..io.result import write_json
    from ..report.uvw import write_report_from_folder

    with staging(out) as tmp:
        summary = result.summary()
        write_json(os.path.join(tmp, "uvw.json"), summary)
        np.savez(os.path.join(tmp, "uvw_samples.npz"), **report_arrays(result))
        write_report_from_folder(tmp, paper=paper)
    return summary


def _fmt(entry):
    return f"{entry['median']:.5g} [{entry['ci95'][0]:.5g}, {entry['ci95'][1]:.5g}]"


def _print_summary(summary):
    from .fit import response_lines

    print(f"UVW calibration ({summary['mode']}), medians [95 % intervals], gains in "
          f"{summary['gain_units']}")
    # a value the prior sets is named as such, never printed as a measurement
    nominal = {k: v for k, v in summary.get("nominal", {}).items() if k != "gain"}
    for entries, order in ((summary["elements"], ("period_s", "damping", "gain")),
                           (summary["xyz"], ("gain", "period_s", "damping"))):
        for name, entry in entries.items():
            resp = {p: entry[p] for p in (*order, "damping_over_period") if p in entry}
            print(f"  {name}: " + "; ".join(response_lines({"response": resp,
                                                             "nominal": nominal}, fmt=_fmt)))
    ct = summary["cross_talk_max"]
    print(f"  largest cross-talk {100 * ct['median']:.3g} % "
          f"[{100 * ct['ci95'][0]:.3g}, {100 * ct['ci95'][1]:.3g}] ({summary['cross_talk_max_pair']})")
    if "agreement" in summary:
        print(f"  Z-only vs all outputs: {summary['agreement']['note']} "
              f"(max |z| {summary['agreement']['max_abs_z']:.2f})")


def rotate_file(args):
    """``--rotate``: X, Y, Z -> U, V, W (or back) with the chosen geometry,
    written atomically to ``DIR/<name>_uvw.mseed`` (``_xyz``)."""
    from obspy import read

    from .. import coil

    if (args.matrix or "").lower() == "identity":
        raise InputError("--rotate with --matrix identity would change nothing")
    m = coil.load_matrix(args.matrix) if args.matrix else coil.sensor_matrix(args.sensor)[0]
    try:
        st = read(args.rotate)
    except Exception as exc:
        raise InputError(f"{args.rotate}: not a readable waveform file ({exc})") from None
    axes = {coil.output_axis(tr.stats.channel) for tr in st}
    to_uvw = set(coil.XYZ) <= axes
    if not to_uvw and not set(coil.ELEMENTS) <= axes:
        raise InputError(f"{args.rotate}: needs three X, Y, Z (1/N, 2/E, Z) or U, V, W channels")
    out = (coil.xyz_to_uvw if to_uvw else coil.uvw_to_xyz)(st, m, source=args.rotate)
    os.makedirs(args.out, exist_ok=True)
    stem = os.path.splitext(os.path.basename(args.rotate))[0]
    path = os.path.join(args.out, f"{stem}_{'uvw' if to_uvw else 'xyz'}.mseed")
    with atomic_path(path) as tmp:
        out.write(tmp, format="MSEED", encoding="FLOAT64")
    if not args.quiet:
        print(f"rotated {'XYZ to UVW' if to_uvw else 'UVW to XYZ'}: {path}")
    return 0


def run(args):
    """Entry point of ``bayescal uvw``."""
    from .. import coil

    if args.rotate:
        return rotate_file(args)
    if not args.cal or not args.sut_xml:
        raise InputError("bayescal uvw needs --cal U=... --cal V=... --cal W=... and --sut-xml "
                         "(or --rotate FILE)")
    runs, m, source = load_inputs(args)
    band = tuple(args.band) if args.band else None
    with quiet_convergence_warnings():
        result = coil.calibrate_uvw(runs, m, coil_constant=args.coil_constant, band=band,
                                   z_only=args.z_only, seed=args.seed, progress=not args.quiet,
                                   matrix_source=source, max_steps=args.max_steps,
                                   priors=priors_from(args))
    summary = write_outputs(result, args.out, paper=args.paper)
    _print_summary(summary)  # --quiet removes the progress display only
    from .common import say, written
    say(args, f"wrote {os.path.abspath(args.out)} ({', '.join(written(args.out))})")
    chains = [(f"the sampler of element {e}", v["convergence"])
              for e, v in summary["elements"].items()]
    chains += [(f"the sampler of element {e} (Z only)", v["convergence"])
               for e, v in summary.get("z_only", {}).items()]
    return convergence_exit(chains)
