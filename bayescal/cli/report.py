"""Render the report of a saved bayescal folder, from its files alone.

A fit's folder (``bayescal fit``: result.json, samples.npz) gets
DIR/report.pdf (summary, angle intervals, data and fit, response,
self-noise; with --full also the corner plots and the convergence page),
and with --png one PNG per page (DIR/report_*.png); truth markers are
drawn when DIR/truth.json (simulate's format) is present. A ``bayescal
diagnose`` folder gets that report and its diagnosis page
(DIR/diagnosis.pdf, .png, from diagnosis.json). A folder of ``bayescal
cal``, ``uvw`` or ``noise`` gets its own report, redrawn from its JSON and
npz files, and a ``bayescal batch`` folder its summary report (report.pdf,
report.png and flags.csv, from results.csv).

Example:
    bayescal report out/ --threshold 3
"""
from __future__ import annotations

from ..report.collection import collection_left_to_exit, collection_paused
from .common import add_paper_argument, add_report_pages_arguments

HELP = "redraw the report of a saved fit, diagnose, cal, uvw, noise or batch folder"

#: What each command leaves in its folder, by which the report is chosen.
OUTPUTS = (("result.json", "bayescal fit or diagnose"), ("cal.json", "bayescal cal"),
           ("uvw.json", "bayescal uvw"), ("noise.json", "bayescal noise"),
           ("results.csv", "bayescal batch"))


def configure(parser):
    """Arguments of ``bayescal report``."""
    from ..report.flags import FLAG_THRESHOLD_DEG
    parser.add_argument("folder", metavar="DIR",
                        help="a folder that bayescal fit, diagnose, cal, uvw, noise or batch "
                             "wrote")
    parser.add_argument("--threshold", type=float, default=FLAG_THRESHOLD_DEG, metavar="DEG",
                        help="flag azimuth, dip or tilt off nominal by more than DEG degrees "
                             f"(default {FLAG_THRESHOLD_DEG:g}, as bayescal batch)")
    parser.add_argument("--truth", metavar="JSON", default=None,
                        help="simulation truth for truth markers (default DIR/truth.json)")
    add_report_pages_arguments(parser)
    add_paper_argument(parser)


def run(args):
    """Render the report with Python's cyclic garbage collection paused while
    it draws; when the command is the whole process (``args.own_process``,
    the console command), the collection is also left to the process's exit
    (:func:`bayescal.report.collection.collection_left_to_exit`). Returns
    the exit code."""
    paused = collection_left_to_exit if getattr(args, "own_process", False) else collection_paused
    with paused():
        return _draw(args)


def _draw(args):
    import os

    from ..errors import InputError
    from ..report.fit import write_report

    if not args.threshold > 0:
        raise InputError(f"--threshold must be a positive angle in degrees, got {args.threshold}")
    folder = args.folder
    if not os.path.isdir(folder) or os.path.isfile(os.path.join(folder, "result.json")):
        paths = write_report(folder, nominal_tolerance_deg=args.threshold, truth=args.truth,
                             paper=args.paper, png=args.png, full=args.full)
        shown = paths[0] if os.path.isabs(folder) else os.path.relpath(paths[0])
        print(f"report: {shown}" + (f" ({len(paths) - 1} PNG figures)" if args.png else ""))
        if os.path.isfile(os.path.join(folder, "diagnosis.json")):
            print(f"diagnosis page: {_diagnosis_page(folder, args.paper)}")
        return 0
    other = _other_report(folder, args)
    if other is None:
        raise InputError(f"{folder}: holds no file a report is drawn from: "
                         + ", ".join(f"{name} ({cmd})" for name, cmd in OUTPUTS[:-1])
                         + f" or {OUTPUTS[-1][0]} ({OUTPUTS[-1][1]})")
    pdfs = [p for p in other if p.endswith(".pdf")]
    print(f"report: {', '.join(pdfs)} ({len(other) - len(pdfs)} PNG figures)")
    return 0


def _diagnosis_page(folder, paper):
    """Redraw a ``bayescal diagnose`` folder's page from its diagnosis.json;
    returns the PDF's path."""
    import json
    import os

    from ..criticism.diagnosis import SavedDiagnosis
    from ..errors import InputError
    from ..report.diagnosis import write_page

    path = os.path.join(folder, "diagnosis.json")
    try:
        with open(path) as fh:
            saved = SavedDiagnosis(json.load(fh))
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(f"{path}: cannot read the saved diagnosis ({exc})") from None
    write_page(saved, os.path.join(folder, "diagnosis"), paper=paper)
    return os.path.join(folder, "diagnosis.pdf")


def _other_report(folder, args):
    """The report of a ``bayescal cal``, ``uvw``, ``noise`` or ``batch``
    folder, redrawn from its files: the paths written (None when the folder
    holds none of their files)."""
    import os

    def has(name):
        return os.path.isfile(os.path.join(folder, name))

    if has("uvw.json"):
        from ..report.uvw import write_report_from_folder
    elif has("noise.json"):
        from ..report.noise import write_report_from_folder
    elif has("cal.json") or any(os.path.isfile(os.path.join(folder, d, "cal.json"))
                                for d in os.listdir(folder)):
        from ..report.cal import write_report_from_folder
    elif has("results.csv"):
        from ..report.batch import write_report
        p = write_report(os.path.join(folder, "results.csv"), folder,
                         threshold_deg=args.threshold, paper=args.paper)
        return [p["pdf"], p["png"]]
    else:
        return None
    return write_report_from_folder(folder, paper=args.paper)
