"""Shared layout of report pages: the page context, style, PNG output,
number formatting, tables and page headers, and :func:`write_pages`, which
writes every report's pages into its PDF and PNGs.

One visual style for every report (fit, cal, uvw, noise, diagnose, batch):
draw inside :func:`style` (fonts, grid, extractable PDF text), head each
page with :func:`page_header` (bold title, small note at the top left),
draw lines in :data:`GREYS` with :data:`LINESTYLES` and :data:`MARKERS`,
put legends beside the axes (:func:`legend_beside`), size tables with
:func:`fit_columns` and let long text run on with :func:`flow_text`.
"""
from __future__ import annotations

import contextlib
import functools
import logging
import textwrap
from dataclasses import dataclass
from datetime import datetime, timezone

import matplotlib

from ..criticism.words import posterior_text
from ..result import Convergence
from ..version import __version__


A4 = (8.27, 11.69)
#: Paper sizes (portrait, inches) every PDF page is written on; ``--paper``.
PAPER = {"a4": A4, "letter": (8.5, 11.0)}
PNG_DPI = 90
#: 2-D contour levels of the corner plots: fractions of posterior mass enclosed.
CORNER_LEVELS = (0.68, 0.95)
#: 1-D quantiles marked by dashed lines in the corner plots.
CORNER_QUANTILES = (0.16, 0.5, 0.84)
LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 3)))
MARKERS = ("o", "s", "^", "v", "D", "P", "X", "*")
GREYS = ("0.0", "0.35", "0.55", "0.15", "0.45", "0.65")
QUANTITY_UNITS = {"azimuth": "deg", "dip": "deg", "tilt": "deg", "orthogonality": "deg",
                  "period_s": "s",
                  "damping": "-", "gain": "stage-1 units per m/s",
                  "relative_gain": "fitted / metadata", "damping_over_period": "1/s"}
QUANTITY_NAMES = {"period_s": "period", "relative_gain": "relative gain",
                  "damping_over_period": "damping/period"}
PARAM_UNITS = {"orient_a": "gnomonic, ~rad", "orient_b": "gnomonic, ~rad",
               "azimuth_rad": "rad", "c0_rel": "(T_nom/T)^2", "c1_rel": "(h/h_nom)(T_nom/T)",
               "damping": "dimensionless",
               "log_gain": "ln of gain"}


def page_size(paper="a4", landscape=False):
    """(width, height) in inches of one page of ``paper`` ("a4" or "letter")."""
    try:
        w, h = PAPER[str(paper).lower()]
    except KeyError:
        raise ValueError(f"paper must be one of {', '.join(PAPER)}, not {paper!r}") from None
    return (h, w) if landscape else (w, h)


def save_pdf_page(pdf, fig, page):
    """Add ``fig`` to the open ``PdfPages`` on a page of exactly ``page``
    inches: a smaller figure sits at the top, centred, on white. Every page
    of one PDF thus has the same size. A figure larger than the page is a
    layout error."""
    from matplotlib.transforms import Bbox

    w, h = fig.get_size_inches()
    pw, ph = page
    if w > pw + 1e-6 or h > ph + 1e-6:
        raise ValueError(f"figure {w:.2f} x {h:.2f} in does not fit a {pw} x {ph} in page")
    pdf.savefig(fig, bbox_inches=Bbox.from_bounds((w - pw) / 2, h - ph, pw, ph))


@dataclass
class ReportContext:
    """Everything the pages draw from; ``page`` is the paper size (inches);
    ``full``: every page, also those a fit's report draws on request
    (:data:`bayescal.report.fit.ON_REQUEST`)."""

    folder: str
    post: object
    summary: dict
    truth: dict | None
    tolerance_deg: float
    page: tuple = A4
    full: bool = True


@contextlib.contextmanager
def style():
    """Report style: the PDF's text in the standard PDF font Helvetica
    (:func:`core_fonts`), ASCII minus signs, thin grid, small fonts that stay
    inside the page. Titles sit just above their axes (``axes.titley``; no
    report axes has tick labels on top), so drawing does not measure every
    axis to place them."""
    with matplotlib.rc_context({"pdf.fonttype": 3, "axes.unicode_minus": False,
                                "axes.titley": 1.0,
                                "font.size": 8, "axes.titlesize": 8, "axes.labelsize": 8,
                                "xtick.labelsize": 7, "ytick.labelsize": 7,
                                "legend.fontsize": 7, "axes.grid": True, "grid.color": "0.85",
                                "grid.linewidth": 0.5, "savefig.facecolor": "white"}):
        yield


#: The text encoding of the PDF's standard fonts (WinAnsiEncoding).
CORE_ENCODING = "cp1252"


def _strings(fig):
    """The text of ``fig`` (a Figure or SubFigure): its texts and legends,
    and each axes' texts, titles, axis labels, legend and tables; tick
    labels are numbers. Read without walking every artist (which would
    make every tick)."""
    for t in fig.texts:
        yield t.get_text()
    for leg in fig.legends:
        yield from (t.get_text() for t in (leg.get_title(), *leg.get_texts()))
    for ax in fig.axes:
        yield from (t.get_text() for t in ax.texts)
        yield from (ax.get_title(loc) for loc in ("left", "center", "right"))
        yield from (ax.get_xlabel(), ax.get_ylabel())
        if ax.get_legend() is not None:
            leg = ax.get_legend()
            yield from (t.get_text() for t in (leg.get_title(), *leg.get_texts()))
        for tab in ax.tables:
            yield from (c.get_text().get_text() for c in tab.get_celld().values())
    for sub in fig.subfigs:
        yield from _strings(sub)


def _in_core_encoding(fig):
    """True when all the text of ``fig`` is in :data:`CORE_ENCODING`."""
    try:
        for text in _strings(fig):
            text.encode(CORE_ENCODING)
    except UnicodeEncodeError:
        return False
    return True


class _StandardFontWeight(logging.Filter):
    """Drops matplotlib's warning that a standard PDF font (Helvetica,
    Courier, ...) has no weight "normal": the standard fonts' metrics (AFM)
    name their regular faces "Medium"."""

    def filter(self, record):
        return not (str(record.msg).startswith("findfont: Failed to find font weight")
                    and len(record.args or ()) > 1
                    and str(record.args[1]).startswith(("Helvetica", "Courier", "Times")))


@contextlib.contextmanager
def core_fonts(fig):
    """Draw ``fig`` into a PDF in the standard PDF fonts (Helvetica, text
    as strings in the font's encoding, no font embedded; matplotlib's
    ``pdf.use14corefonts``) when all its text is in their encoding
    (:data:`CORE_ENCODING`), else in Type 3 fonts (DejaVu glyphs embedded).
    Drawn in the standard fonts, text costs no glyph layout (its widths are
    the font's metrics), which is most of a page's drawing time in Type 3.
    Helvetica is narrower than DejaVu Sans, in which the layout is measured
    (Agg; the PNGs): text placed to fit in DejaVu fits in Helvetica."""
    log = logging.getLogger("matplotlib.font_manager")
    quiet = _StandardFontWeight()
    log.addFilter(quiet)
    try:
        with matplotlib.rc_context({"pdf.use14corefonts": _in_core_encoding(fig),
                                    "axes.unicode_minus": False}):
            yield
    finally:
        log.removeFilter(quiet)


def save_png(fig, path, dpi=PNG_DPI):
    """Write ``fig`` as an 8-bit greyscale PNG (the report draws in greys
    only, so nothing is lost and the file is about half the size). The Agg
    pixel buffer goes straight to Pillow, without an intermediate PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    old_dpi = fig.dpi
    fig.dpi = dpi
    try:
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        rgba = canvas.buffer_rgba()
        Image.frombuffer("RGBA", (rgba.shape[1], rgba.shape[0]), rgba, "raw", "RGBA", 0, 1) \
            .convert("L").save(path)
    finally:
        fig.dpi = old_dpi


def write_pages(pages, pdf_path, *, page=None, dpi=PNG_DPI, grey=True, metadata=None):
    """Write a report's pages: each figure on one page of the PDF
    ``pdf_path`` and, when it has a PNG path, as that PNG, its ticks made
    only where they are drawn (:func:`bayescal.report.in_view.ticks_in_view`).
    Each figure is closed once written; each file is written under a temporary name and
    renamed when complete (:func:`bayescal.atomic.atomic_path`).

    Parameters
    ----------
    pages : iterable of ``(png_path or None, figure)``; a generator builds
        one figure at a time.
    pdf_path : the PDF's path.
    page : (width, height) in inches of every PDF page (:func:`save_pdf_page`);
        None: each page the size of its figure.
    dpi : resolution of the PNGs.
    grey : PNGs in 8-bit greyscale (:func:`save_png`), else in colour as
        matplotlib writes them.
    metadata : the PDF's metadata (as ``PdfPages`` takes them).

    Returns
    -------
    list of the PNG paths written, in page order.
    """
    import sys

    from matplotlib.backends.backend_pdf import PdfPages

    from ..atomic import atomic_path
    from .in_view import ticks_in_view

    pngs = []
    with atomic_path(pdf_path) as tmp, PdfPages(tmp, metadata=metadata) as pdf:
        for png, fig in pages:
            ticks_in_view(fig)
            with core_fonts(fig):
                if page is None:
                    pdf.savefig(fig)
                else:
                    save_pdf_page(pdf, fig, page)
            if png is not None:
                with atomic_path(png) as tmp_png:
                    if grey:
                        save_png(fig, tmp_png, dpi)
                    else:
                        fig.savefig(tmp_png, dpi=dpi)
                pngs.append(png)
            plt = sys.modules.get("matplotlib.pyplot")   # a figure pyplot made is pyplot's
            if plt is not None:
                plt.close(fig)
    return pngs


def subject_line(ctx):
    """One line for the PDF Subject: channels, band, window."""
    m = ctx.post.meta
    band = m.band_hz or [None, None]
    return (f"Orientation{' and response' if (m.free_response or 'none') != 'none' else ''}"
            f" of {', '.join(ctx.post.channel_ids)}; band {_g(band[0], '{:.4g}')}-"
            f"{_g(band[1], '{:.4g}')} Hz;"
            f" start {m.starttime or '?'}, {_g(m.duration_s)} s")


def _g(x, fmt="{:g}"):
    return "?" if x is None else fmt.format(x)


def fmt_value(quantity, x):
    """Printed precision of a table value: angles to 0.01 deg, responses to
    four significant figures."""
    if x is None:
        return "-"
    if quantity in ("azimuth", "dip", "tilt", "orthogonality"):
        return f"{x:.2f}"
    return f"{x:.4g}"


def _fmt_ci(quantity, ci):
    return "-" if not ci else f"[{fmt_value(quantity, ci[0])}, {fmt_value(quantity, ci[1])}]"


def _fmt_dev(row):
    if row.deviation is None:
        return "-"
    if row.quantity in ("azimuth", "dip", "tilt", "orthogonality"):
        return f"{row.deviation:+.2f}"
    return f"{row.deviation:+.2f} %"


#: Height of one table row as a fraction of a page's height (6.5 pt text on A4).
ROW_H = 0.0150


def summary_table(fig, top, rows, title, with_truth):
    """Draw a summary table whose top edge is at figure fraction ``top``
    (its cells placed once, :mod:`bayescal.report.placed_table`); returns
    the figure fraction just below it."""
    from .placed_table import placed_table

    labels = ["channel", "quantity", "median", "68 % interval", "95 % interval", "nominal",
              "deviation"] + (["truth"] if with_truth else []) + ["note"]
    cells = []
    for r in rows:
        c = [r.channel, f"{QUANTITY_NAMES.get(r.quantity, r.quantity)}"
             f" ({r.unit or QUANTITY_UNITS.get(r.quantity, '')})",
             fmt_value(r.quantity, r.median), _fmt_ci(r.quantity, r.ci68),
             _fmt_ci(r.quantity, r.ci95), fmt_value(r.quantity, r.nominal), _fmt_dev(r)]
        cells.append(c + ([fmt_value(r.quantity, r.truth)] if with_truth else []) + [r.note])
    fig.text(0.05, top, title, fontweight="bold", va="top")
    cells, widths, n_lines = fit_columns([labels] + cells, 0.9 * fig.get_figwidth(), TABLE_PT)
    rows_h = [ROW_H * (1 + LINE_H * (n - 1)) for n in n_lines]
    height = sum(rows_h)
    ax = fig.add_axes([0.05, top - 0.02 - height, 0.9, height])
    ax.axis("off")
    placed_table(ax, cells, widths, [h / height for h in rows_h], TABLE_PT)
    return top - 0.02 - height - 0.025


#: Font size (points) of the summary tables; a wrapped cell's second and
#: later lines add this fraction of a row's height each.
TABLE_PT = 6.5
LINE_H = 0.62
#: Fraction of a cell's width matplotlib leaves as padding on each side (``Cell.PAD``).
CELL_PAD = 0.1


def _text_width_in(text, size):
    """Width in inches of ``text`` (its longest line) at ``size`` points."""
    return max(_line_width_in(ln, size) for ln in str(text).split("\n"))


@functools.lru_cache(maxsize=4096)
def _line_width_in(line, size):
    """Width in inches of one line of text at ``size`` points in the report's
    font, as Agg lays it out (each line measured once: a table's notes are
    measured at every width tried)."""
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    return RendererAgg(1, 1, 72).get_text_width_height_descent(
        line, FontProperties(size=size), ismath=False)[0] / 72.0


def fit_columns(rows, width_in, size):
    """Column widths for table ``rows`` (header first; lists of strings) so
    that every cell's text fits its cell within ``width_in`` inches: each
    column as wide as its widest text, the last column's text (the notes)
    wrapped into the width left when the columns would not fit.

    Returns ``(rows, widths, lines)``: the rows with wrapped notes, each
    column's width (fractions summing to 1) and each row's number of lines."""
    def need(text):
        return _text_width_in(text, size) / (1 - 2 * CELL_PAD) + 0.02

    widths = [max(need(r[j]) for r in rows) for j in range(len(rows[0]))]
    spare = width_in - sum(widths[:-1])
    if widths[-1] > spare:
        chars = max(len(max((r[-1] for r in rows), key=len)), 12)
        while chars > 12 and max(need(textwrap.fill(r[-1], chars) or " ") for r in rows) > spare:
            chars -= 2
        rows = [r[:-1] + [textwrap.fill(r[-1], chars)] for r in rows]
        widths[-1] = max(spare, max(need(r[-1] or " ") for r in rows))
    total = sum(widths)
    lines = [max(str(c).count("\n") + 1 for c in r) for r in rows]
    return rows, [w / total for w in widths], lines


def _files_line(label, files, width=110):
    text = ", ".join(str(f) for f in files)
    return textwrap.shorten(f"{label}: {text}", width, placeholder=" ...")


def header_lines(ctx):
    """Page-1 header: what was measured, with which data, how."""
    post, m = ctx.post, ctx.post.meta
    conv = ctx.summary["convergence"]
    stations = sorted({".".join(c.split(".")[:2]) for c in post.channel_ids})
    n_used, n_poss = m.n_segments, m.n_segments_possible
    seg = m.segment_s
    used = m.data_used or {}
    dropped = (None if n_used is None or n_poss is None
               else n_poss - n_used - (used.get("transients") or {}).get("dropped", 0))
    band = m.band_hz or [None, None]
    lines = [
        f"Result: {ctx.summary.get('schema', '?')}, rendered"
        f" {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC by bayescal {__version__}",
        f"Station(s): {', '.join(stations)}",
        f"Sensor under test: {', '.join(post.channel_ids)}",
        f"Reference: {', '.join(sorted(m.reference or {}))}"]
    for label, key in (("SUT files", "sut"), ("Reference files", "reference")):
        files = [f for f in (m.files or {}).get(key, [])
                 if f not in ("SUT", "reference", "stream")]      # in-memory stream names
        if files:
            lines.append(_files_line(label, files))
    lines += [
        f"Data window: start {m.starttime or '?'}, duration {_g(m.duration_s, '{:.0f}')} s,"
        f" sampling {_g(m.sampling_rate)} Hz",
        *textwrap.wrap(
            f"Segments used: {_g(n_used)} of {_g(n_poss)} ({_g(seg, '{:.1f}')} s each)"
            + (f", about {used['approx_seconds']:.0f} s of data" if used.get("approx_seconds")
               else "")
            + f"; dropped: {_g(dropped)}"
            + ("" if not dropped else f" ({used.get('note', 'gaps or bad data')})"), 120),
        f"Band: {_g(band[0], '{:.4g}')} - {_g(band[1], '{:.4g}')} Hz in"
        f" {max(len(m.band_edges_hz if m.band_edges_hz is not None else []) - 1, 0)}"
        f" sub-bands; response fitted: {m.free_response or 'none'}"]
    if used.get("transients"):
        tr = used["transients"]
        lines += textwrap.wrap(
            f"Transients: {tr['dropped']} segments left out, in which one sensor recorded "
            f"{min(tr['ratio']):.3g}-{max(tr['ratio']):.3g} times the incoherent power of the "
            f"minutes around", 120)
    if m.reference_tolerance:
        lines += textwrap.wrap(
            f"Reference metadata: gain, period and damping known to "
            f"{100 * m.reference_tolerance['relative_sd']:g} % (1 sd), carried into the "
            f"SUT's response intervals", 120)
    if m.band_choice:
        lines += textwrap.wrap(f"Band choice: {m.band_choice}", 120)
    if m.assumption:
        lines += textwrap.wrap(f"Assumed: {m.assumption}", 120)
    if m.reference_noise:
        from ..core.posterior import describe_treatment
        lines += textwrap.wrap(f"Reference's self-noise: {describe_treatment(m.reference_noise)}",
                               120)
    return lines + _posterior_lines(ctx.summary, m, conv)


def _posterior_lines(summary, m, conv):
    """The header's line on how the posterior was computed: the method that
    is no chain, the Laplace approximation, or the sampler's figures."""
    if m.method:
        return [f"Posterior: {m.method}, {conv['ess_min']:.0f} independent draws"]
    if posterior_text(summary):
        return textwrap.wrap(f"Posterior: {posterior_text(summary)}", 120)
    return [sampler_line(conv)]


def sampler_line(conv):
    """One line on a sampler's run from its ``convergence`` entry (as
    result.json, cal.json and uvw.json hold it), in the words every report uses."""
    return (f"Sampler: {conv['n_walkers']} walkers x {conv['n_steps']} steps,"
            f" {Convergence.figures(conv)}, converged: {'yes' if conv['converged'] else 'NO'}")


#: Lowest figure fraction a page's text may reach (the page's bottom margin).
BOTTOM = 0.02


def text_extent(fig, artist):
    """The extent of ``artist`` (a text, table or axes) in figure fractions,
    as matplotlib's Agg renderer lays it out: ``(x0, y0, x1, y1)``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    box = artist.get_window_extent(fig.canvas.get_renderer())
    w, h = fig.bbox.width, fig.bbox.height
    return box.x0 / w, box.y0 / h, box.x1 / w, box.y1 / h


def flow_text(fig, x, y, lines, new_page, bottom=BOTTOM, **kw):
    """Write ``lines`` from figure fraction ``(x, y)`` down (``va="top"``),
    measuring the text's extent; the lines below ``bottom`` go on to
    continuation pages, each made by ``new_page()`` as ``(figure, y)``.

    Returns the figures written on, ``fig`` first (one when all fit)."""
    figs = [fig]
    lines = list(lines)
    while lines:
        art = fig.text(x, y, "\n".join(lines), va="top", **kw)
        y0 = text_extent(fig, art)[1]
        n = len(lines)
        while y0 < bottom and n > 0:              # drop the lines that fall off, measured
            per_line = (y - y0) / n
            n = min(n - 1, max(int((y - bottom) / per_line), 0))
            art.set_text("\n".join(lines[:n]))
            y0 = text_extent(fig, art)[1] if n else y
        if n == 0:
            art.remove()
        lines = lines[n:]
        while lines and not lines[0].strip():     # a page does not start blank
            lines.pop(0)
        if lines:
            fig, y = new_page()
            figs.append(fig)
    return figs


def legend_beside(ax, *args, **kw):
    """The legend of ``ax`` beside it, to the right of its top edge: never
    over a curve (the style of every report page; the axes leave room)."""
    return ax.legend(*args, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                     **kw)


def page_header(fig, title, note, width):
    """A page's title (bold) and its note (small, wrapped to the page's
    ``width`` in inches) at the top left: the head every report page has."""
    height = fig.get_figheight()
    note = "\n".join(textwrap.fill(par, int(width * 15)) for par in note.split("\n"))
    fig.text(0.02, 1 - 0.15 / height, title, fontsize=11, fontweight="bold", va="top")
    fig.text(0.02, 1 - 0.45 / height, note, fontsize=7, va="top")

