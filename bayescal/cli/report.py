"""Render the calibration report of a saved result folder.

Writes DIR/report.pdf (summary, angle intervals, corner plots, data and fit,
convergence) and one PNG per figure (DIR/report_*.png). Truth markers are
drawn when DIR/truth.json (simulate's format) is present. A folder of
`bayescal cal`, `bayescal uvw` or `bayescal noise` gets its own report,
redrawn from its JSON and npz files.

Example:
    bayescal report out/ --threshold 3
"""
from __future__ import annotations

from .common import add_paper_argument

HELP = "render report.pdf and report_*.png for a saved result folder"


def configure(parser):
    """Arguments of ``bayescal report``."""
    parser.add_argument("folder", metavar="DIR", help="result folder (result.json, samples.npz)")
    parser.add_argument("--threshold", type=float, default=5.0, metavar="DEG",
                        help="flag angles off nominal by more than DEG degrees (default 5)")
    parser.add_argument("--truth", metavar="JSON", default=None,
                        help="simulation truth for truth markers (default DIR/truth.json)")
    add_paper_argument(parser)


def run(args):
    """Render the report; returns the exit code."""
    import os

    from ..errors import InputError
    from ..report.fit import write_report

    if not args.threshold > 0:
        raise InputError(f"--threshold must be a positive angle in degrees, got {args.threshold}")
    other = _other_report(args.folder, args.paper)
    if other is not None:
        pdfs = [p for p in other if p.endswith(".pdf")]
        print(f"report: {', '.join(pdfs)} ({len(other) - len(pdfs)} PNG figures)")
        return 0
    paths = write_report(args.folder, nominal_tolerance_deg=args.threshold, truth=args.truth,
                         paper=args.paper)
    shown = paths[0] if os.path.isabs(args.folder) else os.path.relpath(paths[0])
    print(f"report: {shown} ({len(paths) - 1} PNG figures)")
    return 0


def _other_report(folder, paper):
    """The report of a ``bayescal cal``, ``uvw`` or ``noise`` folder, redrawn
    from its files (None for a pair fit's folder)."""
    import os

    if os.path.isfile(os.path.join(folder, "result.json")) or not os.path.isdir(folder):
        return None
    if os.path.isfile(os.path.join(folder, "uvw.json")):
        from ..report.uvw import write_report_from_folder
    elif os.path.isfile(os.path.join(folder, "noise.json")):
        from ..report.noise import write_report_from_folder
    elif os.path.isfile(os.path.join(folder, "cal.json")) or any(
            os.path.isfile(os.path.join(folder, d, "cal.json")) for d in os.listdir(folder)):
        from ..report.cal import write_report_from_folder
    else:
        return None
    return write_report_from_folder(folder, paper=paper)
