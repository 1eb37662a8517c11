"""What several sub-commands share: the arguments of a sensor pair, the page size, messages
on stderr, and the output folder written in a staging folder and published when complete
(:func:`bayescal.atomic.staging`)."""
from __future__ import annotations

import contextlib
import sys

from ..atomic import staging  # noqa: F401  (the sub-commands' one output rule)


def parse_time(text):
    import argparse

    from obspy import UTCDateTime
    try:
        return UTCDateTime(text)
    except Exception:
        raise argparse.ArgumentTypeError(f"not a time: {text!r} (use e.g. 2010-08-24T02:00:00)")


def _percent(text):
    import argparse
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < 1000:
        raise argparse.ArgumentTypeError(f"not a tolerance in per cent: {text!r} (e.g. 5)")
    return value


def _percent_or_zero(text):
    return 0.0 if text.strip() in ("0", "0.0") else _percent(text)


def priors_from(args):
    """The fit's :class:`bayescal.core.priors.Priors` from the options."""
    from ..core.priors import Priors
    return Priors(period_tolerance=args.period_tolerance / 100.0,
                  damping_tolerance=args.damping_tolerance / 100.0,
                  reference_tolerance=getattr(args, "ref_tolerance", 0.0) / 100.0)


def add_tolerance_arguments(parser, when):
    """``--period-tolerance`` and ``--damping-tolerance`` (per cent): the
    stated prior on natural period and damping (:mod:`bayescal.core.response.pendulum`),
    which applies ``when`` (e.g. "with --fit-response all")."""
    from ..core.response import DAMPING_TOLERANCE, PERIOD_TOLERANCE

    parser.add_argument("--period-tolerance", type=_percent, default=100 * PERIOD_TOLERANCE,
                        metavar="PERCENT",
                        help=f"{when}: the prior on each natural period, "
                             "log-normal around the metadata value with this standard deviation "
                             "in per cent (the manufacturer's tolerance; default "
                             f"{100 * PERIOD_TOLERANCE:g}). A period the prior sets is reported "
                             "as such, not as a measurement")
    parser.add_argument("--damping-tolerance", type=_percent, default=100 * DAMPING_TOLERANCE,
                        metavar="PERCENT",
                        help=f"{when}: the prior on each damping, as "
                             f"--period-tolerance (default {100 * DAMPING_TOLERANCE:g})")


def add_pair_arguments(parser):
    """Arguments shared by ``bayescal fit`` and ``bayescal diagnose``: the two
    sensors' files, the output folder, the band, the window and the options."""
    _add_inputs(parser)
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--fit-response", nargs="?", const="all", default="gain",
                        choices=["all", "gain", "none"],
                        help="which of the SUT's response parameters are fitted: 'gain' (the "
                             "default without the option: each channel's gain, reported also "
                             "as a relative gain = fitted / metadata; works with 'flat' "
                             "metadata), 'all' (the default when the option is given without "
                             "a value: natural period, damping and gain per channel; needs "
                             "poles and zeros) or 'none' (gains held at their metadata values, "
                             "angles only). With one horizontal reference channel the gains "
                             "are held (it cannot separate them from the rotation)")
    add_tolerance_arguments(parser, "with --fit-response all")
    _add_reference_arguments(parser)
    parser.add_argument("--keep-transients", action="store_true",
                        help="fit every Welch segment; by default segments in which one sensor "
                             "records noise the other does not, beyond the record's stationary "
                             "noise (a transient near one sensor: a gust, a door, a vehicle), "
                             "are left out, and the console says how many and when")
    parser.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"),
                        help="analysis band in Hz (default: chosen from the data where the "
                             "sensors are coherent)")
    parser.add_argument("--start", type=parse_time, metavar="T",
                        help="start of the analysis window, e.g. 2010-08-24T02:00:00")
    parser.add_argument("--end", type=parse_time, metavar="T", help="end of the analysis window")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress display (each stage's line or bar on stderr: least "
                             "squares, mode search, sampling, criticism); errors, the band used "
                             "and the results table are still printed")
    parser.add_argument("--no-report", action="store_true", help="do not write the PDF report")
    add_sampling_argument(parser)
    add_paper_argument(parser)


def _add_inputs(parser):
    """The two sensors' recordings, metadata and channel patterns."""
    g = parser.add_argument_group("inputs")
    g.add_argument("--ref", nargs="+", required=True, metavar="FILE",
                   help="reference recording(s): miniSEED or any format ObsPy reads")
    g.add_argument("--ref-xml", required=True, metavar="XML",
                   help="reference metadata: StationXML (azimuth, dip, response), a RESP file, "
                        "a GSE2 .cal poles-and-zeros file, or 'flat'")
    g.add_argument("--sut", nargs="+", required=True, metavar="FILE",
                   help="recording(s) of the sensor under test")
    g.add_argument("--sut-xml", required=True, metavar="XML",
                   help="SUT nominal metadata: StationXML, RESP, GSE2 .cal, or 'flat'")
    g.add_argument("--sut-id", nargs="+", metavar="PATTERN",
                   help="SEED ids of the SUT's channels, wildcards allowed (e.g. "
                        "'XX.SIM.10.BH?'): needed when a file holds both sensors")
    g.add_argument("--ref-id", nargs="+", metavar="PATTERN",
                   help="SEED ids of the reference's channels (e.g. 'XX.SIM.00.BH?')")


def _add_reference_arguments(parser):
    """What is known of the reference: its metadata's tolerance and its self-noise."""
    parser.add_argument("--ref-tolerance", type=_percent_or_zero, default=0.0,
                        metavar="PERCENT",
                        help="how well the reference's own metadata are known: the relative "
                             "standard deviation in per cent of its gain, natural period and "
                             "damping, carried into the SUT's gain, period and damping "
                             "intervals (default 0: taken as exact, as a relative calibration "
                             "does; the SUT's response is then measured against the "
                             "reference's metadata)")
    parser.add_argument("--ref-noise", choices=["quiet", "estimate", "equal"], default=None,
                        help="the reference's own self-noise: 'estimate' (estimated from the "
                             "data as white in ground units plus white in the reference's "
                             "counts: unbiased whether the reference is quiet or as noisy as "
                             "the SUT, as in a huddle; the default with two or more channels "
                             "on each side), 'quiet' (negligible next to the SUT's; the default "
                             "for a one-channel pair, which cannot separate it; about 1.5 "
                             "times faster), 'equal' (the same as the SUT's in ground units)")
    parser.add_argument("--ref-noise-psd", metavar="FILE",
                        help="the reference's self-noise as known, instead of --ref-noise: "
                             "bayescal noise's noise.json (from a third co-located sensor: the "
                             "remedy for a one-channel pair such as a vertical huddle) or a text "
                             "file of period (s) and PSD (dB re 1 (m/s^2)^2/Hz) columns")


#: Exit code of a run whose results are written but one of whose samplers
#: stopped at --max-steps before meeting its convergence rule.
EXIT_NOT_CONVERGED = 3
#: The exit codes, as each sampling command's --help states them.
EXIT_CODES = ("Exit codes: 0 success; 2 bad input (one line naming the file and the problem; "
              "nothing is written to DIR); 3 results written, but a sampler stopped at "
              "--max-steps before meeting its convergence rule (a NOT CONVERGED line says "
              "which; its intervals are provisional).")


def add_sampling_argument(parser):
    """``--max-steps N``: the most steps a sampler runs before it stops unconverged."""
    from ..core.budget import SAMPLE_WORK
    parser.add_argument("--max-steps", type=int, default=None, metavar="N",
                        help="most steps a sampler runs before it stops without meeting its "
                             f"convergence rule (default: what {SAMPLE_WORK} model evaluations "
                             "allow, 7348 steps at 40 walkers; the run then ends with exit "
                             "code 3 and says so)")


@contextlib.contextmanager
def quiet_convergence_warnings():
    """The CLI states an unconverged chain in its own line (:func:`convergence_exit`)
    and a failed model check in its summary, not as Python warnings."""
    import warnings

    from ..errors import ModelMisfitWarning, NotConvergedWarning
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=NotConvergedWarning)
        warnings.filterwarnings("ignore", category=ModelMisfitWarning)   # said on the console
        yield


def convergence_exit(entries, stream=None):
    """Print one NOT CONVERGED line per unconverged chain; returns the exit code.
    ``entries``: (label, convergence dict) pairs."""
    from ..core.posterior import not_converged_line

    code = 0
    for label, conv in entries:
        line = not_converged_line(conv, what=label)
        if line:
            print(line, file=stream or sys.stdout)
            code = EXIT_NOT_CONVERGED
    return code


def add_report_pages_arguments(parser):
    """``--full`` and ``--png``: the pages of a fit's report beyond the
    default ones, and a PNG per page."""
    parser.add_argument("--full", action="store_true",
                        help="a fit's report: also the corner plots and the convergence page "
                             "(drawn anyway when the posterior is multimodal or the sampler "
                             "did not converge)")
    parser.add_argument("--png", action="store_true",
                        help="a fit's report: also one PNG per page (DIR/report_*.png; "
                             "about as long again to draw as the PDF)")


def add_paper_argument(parser):
    """``--paper a4|letter``: the size of every page of the PDF reports."""
    parser.add_argument("--paper", choices=["a4", "letter"], default="a4",
                        help="page size of every page of the PDF report (default a4)")


def say(args, text):
    if not args.quiet:
        print(text, file=sys.stderr)


def written(folder):
    """The names a user looks for in an output folder, sorted: its files
    and sub-folders, without the hidden list of what bayescal wrote there
    (:data:`bayescal.atomic.MANIFEST`) or other hidden files."""
    import os
    return sorted(n for n in os.listdir(folder) if not n.startswith("."))

