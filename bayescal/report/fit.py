"""Calibration reports: a multi-page PDF (and one PNG per page on request), rendered
from a saved result folder (``result.json``, ``samples.npz``,
``diagnostics.npz``).

    >>> from bayescal.report import write_report
    >>> write_report("out")            # out/report.pdf
    >>> write_report("out", png=True)  # and out/report_*.png

Pages: (1) summary table with flags, (2) angle credible intervals against
nominal, (3) corner plots of the angles (and of the response parameters when
fitted), (4) data and fit (PSDs, coherence, per-band standardised misfit), (5)
the SUT's response relative to the reference's metadata under the headline
model, beside the metadata's (:mod:`.response_curve`), (6) self-noise of
both sensors against the NLNM and NHNM, (7) convergence (traces, tau, ESS,
R-hat, acceptance), and (8) when the criticism's
improved model heads the result, the rejected fit's table. The numbers on the
pages are real PDF text, so they can be searched and extracted.

This module holds the file handling; the numbers are in :mod:`.tables`, the
figures in :mod:`.fit_pages` and :mod:`.corner_pages`.
"""
from __future__ import annotations

import os
from functools import partial

from ..errors import InputError
from .collection import collection_paused
from .tables import load_truth
from .flags import FLAG_THRESHOLD_DEG


#: Figures, in page order.
PAGES = ("summary", "intervals", "corner_angles", "corner_response", "data_fit",
         "response_curve", "self_noise", "convergence", "rejected_fit")


def _builder(name, *modules):
    """The function drawing page ``name`` (``page_<name>`` of one of ``modules``)."""
    return next(getattr(m, f"page_{name}") for m in modules if hasattr(m, f"page_{name}"))


def _named(name, drawn):
    """``(png name, figure)`` of a page builder's result: None (the page does
    not apply), a figure, or a list of figures (a page continued: ``name``,
    ``name_2``, ...)."""
    if drawn is None:
        return []
    if not isinstance(drawn, list):
        return [(name, drawn)]
    return [(name if i == 0 else f"{name}_{i + 1}", fig) for i, fig in enumerate(drawn)]


#: Pages drawn on request (``full``): the posterior's corner plots and the
#: sampler's traces, which page 1 condenses into the intervals and the
#: sampler's figures (ESS, R-hat, converged); each is drawn anyway when page
#: 1 warns of what it shows (:func:`shown`). Without them a report costs
#: about half (docs/report.md).
ON_REQUEST = ("corner_angles", "corner_response", "convergence")


def shown(name, summary, full=False):
    """Whether page ``name`` is drawn for the result ``summary``: every page
    with ``full``; else all but :data:`ON_REQUEST`, and of those the corner
    plots when the posterior is multimodal, the convergence page when the
    sampler did not converge."""
    from ..core.posterior import multimodal_line

    if full or name not in ON_REQUEST:
        return True
    if name == "convergence":
        return not summary["convergence"]["converged"]
    return bool(multimodal_line(summary))


def figures(ctx):
    """``(name, figure)`` of every page of the report of ``ctx`` (a
    :class:`~bayescal.report.layout.ReportContext`) that applies and is
    drawn (:func:`shown`, ``ctx.full``), in page order; a page continued on
    further pages gives ``name_2``, ... ."""
    from . import corner_pages, fit_pages, pair_noise, response_curve

    for name in PAGES:
        if shown(name, ctx.summary, ctx.full):
            yield from _named(name, _builder(name, fit_pages, corner_pages, pair_noise,
                                             response_curve)(ctx))


def _check_folder(folder):
    if not os.path.isdir(folder):
        raise InputError(f"{folder}: no such result folder")
    for name in ("result.json", "samples.npz"):
        if not os.path.exists(os.path.join(folder, name)):
            raise InputError(f"{folder}: not a bayescal result folder ({name} is missing)")


def load_result(folder):
    """Load a saved :class:`~bayescal.result.record.Result`, turning any
    reading problem into an :class:`InputError` naming the folder."""
    from ..result.schema import load as load_posterior
    _check_folder(folder)
    try:
        return load_posterior(folder)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{folder}: cannot read the saved result ({exc})") from None


@collection_paused()
def write_report(folder, out_pdf=None, nominal_tolerance_deg=FLAG_THRESHOLD_DEG, truth=None,
                 paper="a4", *, png=False, full=False):
    """Render the calibration report of the result saved in ``folder``.

    Writes ``folder/report.pdf`` (or ``out_pdf``) and, with ``png``, one PNG
    per figure next to it (``report_<figure>.png``), all drawn in a
    temporary folder and moved into place at the end (a failure leaves
    nothing half-written). An earlier report's PNGs this one does not draw
    are removed: the folder's figures are this report's. The files written
    are listed in the folder's manifest (:data:`bayescal.atomic.MANIFEST`), so a later
    run into the folder (e.g. ``bayescal fit --no-report``) removes them
    rather than leaving an earlier run's report beside its results.

    Parameters
    ----------
    folder : result folder written by :func:`bayescal.write_results`.
    out_pdf : path of the PDF (default ``folder/report.pdf``).
    nominal_tolerance_deg : azimuth/dip/tilt deviation from nominal above
        which a channel is flagged when its 95 % interval excludes nominal
        too: the rule and default (2 deg) of ``bayescal batch``
        (:func:`bayescal.report.flags.off_nominal`).
    truth : simulation truth (dict or JSON path) for truth markers; default
        the meta's ``truth`` entry or ``folder/truth.json`` when present.
    paper : "a4" (default) or "letter": every page of the PDF has this size.
    png : also each page as a PNG (greyscale, 90 dpi; docs/report.md).
    full : also the pages drawn on request (:data:`ON_REQUEST`).

    Returns the list of written paths, each absolute (PDF first). Drawn with
    the cyclic garbage collector paused (:mod:`bayescal.report.collection`).
    """
    from ..atomic import move_files, staging
    from ..version import __version__
    from . import layout

    folder = os.fspath(folder)
    post = load_result(folder)
    truth = load_truth(folder, post.meta, truth)
    summary = post.summary()
    out_pdf = os.fspath(out_pdf) if out_pdf else os.path.join(folder, "report.pdf")
    out_dir = os.path.dirname(os.path.abspath(out_pdf))
    stem = os.path.splitext(os.path.basename(out_pdf))[0]
    ctx = layout.ReportContext(folder=folder, post=post, summary=summary, truth=truth,
                               tolerance_deg=float(nominal_tolerance_deg),
                               page=layout.page_size(paper), full=full)
    stale = [f"{stem}_{name}.png" for name in PAGES] + [   # an earlier report's, if not redrawn
        n for n in (os.listdir(out_dir) if os.path.isdir(out_dir) else ())
        if n.startswith(f"{stem}_summary_") and n.endswith(".png")
        and n[len(stem) + 9:-4].isdigit()]   # page 1's continuations only: _summary_2.png ...
    own = os.path.abspath(out_dir) == os.path.abspath(folder)   # a report in its result's folder
    with layout.style(), staging(out_dir, finish=partial(move_files, stale=stale, record=own),
                                 within=out_dir) as tmp:
        drawn = list(figures(ctx))
        meta = {"Title": f"bayescal calibration report: {', '.join(post.channel_ids)}",
                "Subject": layout.subject_line(ctx), "Creator": f"bayescal {__version__}",
                "Keywords": "seismometer calibration; orientation; Bayesian"}
        written = layout.write_pages(
            [(os.path.join(tmp, f"{stem}_{name}.png") if png else None, fig)
             for name, fig in drawn],
            os.path.join(tmp, os.path.basename(out_pdf)), page=ctx.page, metadata=meta)
    return [os.path.join(out_dir, os.path.basename(p)) for p in [out_pdf, *written]]
