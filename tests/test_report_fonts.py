"""The PDF's text in the standard PDF fonts (:func:`bayescal.report.layout.core_fonts`):
a page whose text the standard fonts' encoding holds is written in Helvetica,
not embedded, and reads back as written; a page with other characters keeps
embedded Type 3 fonts; and the widths the layout measures in DejaVu Sans
(Agg, the PNGs) bound the widths Helvetica gives the same text in the PDF,
so a table sized by :func:`~bayescal.report.layout.fit_columns` holds its
text in the PDF too."""
from __future__ import annotations

import io

import matplotlib
import pytest
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties

pypdf = pytest.importorskip("pypdf")

ROW = "XX.SIM.10.BH1 azimuth (deg) 12.03 [11.52, 12.55] [11.01, 13.06] 0.00 +12.03 -"


def _fonts(path):
    """(subtype, base font name) of each font of the PDF ``path``."""
    fonts = pypdf.PdfReader(str(path)).pages[0]["/Resources"]["/Font"]
    return {(str(f.get_object()["/Subtype"]), str(f.get_object().get("/BaseFont", ""))[-11:])
            for f in fonts.values()}


def test_pages_in_standard_fonts_unless_their_text_needs_others(tmp_path):
    """A page of ASCII text (one line bold) in Helvetica and Helvetica-Bold,
    Type 1, nothing embedded, its text extracted as drawn; a page with a
    Greek sigma and an ohm sign (outside WinAnsiEncoding) in embedded
    Type 3 DejaVu Sans, not in Helvetica with '?' for what it lacks."""
    from bayescal.report.layout import style, write_pages

    plain, other = Figure(figsize=(6, 3)), Figure(figsize=(6, 3))
    plain.text(0.05, 0.8, ROW)
    plain.text(0.05, 0.5, "Flags (tolerance 2 deg)", fontweight="bold")
    other.text(0.05, 0.5, "noise \u03c3 = 1.2 \u03a9")
    with style():
        write_pages([(None, plain)], str(tmp_path / "plain.pdf"))
        write_pages([(None, other)], str(tmp_path / "other.pdf"))
    assert _fonts(tmp_path / "plain.pdf") == {("/Type1", "/Helvetica"),
                                              ("/Type1", "vetica-Bold")}
    assert b"FontFile" not in (tmp_path / "plain.pdf").read_bytes()      # nothing embedded
    text = pypdf.PdfReader(str(tmp_path / "plain.pdf")).pages[0].extract_text()
    assert ROW in text and "Flags (tolerance 2 deg)" in text
    assert _fonts(tmp_path / "other.pdf") == {("/Type3", "+DejaVuSans")}


def _pdf_width_pt(text, size):
    """Width (points) of ``text`` at ``size`` points in the PDF's standard
    fonts, as matplotlib's PDF renderer measures it."""
    from matplotlib.backends.backend_pdf import PdfFile, RendererPdf

    with matplotlib.rc_context({"pdf.use14corefonts": True}):
        renderer = RendererPdf(PdfFile(io.BytesIO()), 72, 72, 72)
        return renderer.get_text_width_height_descent(text, FontProperties(size=size),
                                                      ismath=False)[0]


def test_table_cells_hold_their_text_in_the_pdf(tmp_path):
    """Every cell of a summary table (a long note, upper-case channel codes
    and flags, Helvetica's widest capitals C E F G J K P R S Y among them)
    holds its text in Helvetica: each line's width in the PDF (points) fits
    the cell's width less matplotlib's padding, the cells laid out as the
    PNG (Agg) lays them out."""
    from types import SimpleNamespace

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from bayescal.report.layout import A4, CELL_PAD, TABLE_PT, style, summary_table

    rows = [SimpleNamespace(channel=c, quantity=q, unit=u, median=m, ci68=(m - 1, m + 1),
                            ci95=(m - 2, m + 2), nominal=0.0, deviation=m, truth=None, note=n)
            for c, q, u, m, n in (
                ("XX.SIM.10.BH1", "azimuth", "deg", 12.03, "AZIMUTH OFF: SPECKLED JERKY GYRO"),
                ("CY.FGKJ.00.SPY", "gain", "COUNTS PER JERK", 1234.5,
                 "the reference's self-noise: a long note that the table wraps into the "
                 "width left to it, CEFGJKPRSY CEFGJKPRSY CEFGJKPRSY CEFGJKPRSY"))]
    fig = Figure(figsize=A4)
    with style():
        summary_table(fig, 0.9, rows, "Orientation", False)
        FigureCanvasAgg(fig).draw()
        renderer = fig.canvas.get_renderer()
        cells = [c for ax in fig.axes for t in ax.tables for c in t.get_celld().values()]
        assert len(cells) == 3 * 8
        for cell in cells:
            room = cell.get_window_extent(renderer).width * 72 / fig.dpi * (1 - 2 * CELL_PAD)
            for line in cell.get_text().get_text().split("\n"):
                assert _pdf_width_pt(line, TABLE_PT) <= room, (line, room)


def test_a_legend_title_outside_the_standard_encoding_keeps_embedded_fonts():
    """A legend's title is text of the page: one in Greek (outside the
    standard fonts' encoding) keeps the page in embedded fonts, so that no
    character is lost."""
    from bayescal.report.layout import _in_core_encoding

    fig = Figure()
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1], label="a")
    ax.legend(title="noise")
    assert _in_core_encoding(fig)
    ax.legend(title="σ noise")
    assert not _in_core_encoding(fig)
