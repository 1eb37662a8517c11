"""The batch report's pages in the style of every report: rendered once
(Agg) at the report's page size through :func:`bayescal.report.batch.write_report`,
each page is checked by tests/figures.py (no text off the page, no table
text outside its cell, no legend over a curve or naming a curve not drawn);
the pages draw in the report's greys; the flags table is the fit report's
(:func:`bayescal.report.layout.summary_table`) with the flagged results'
numbers. A failed item's error in results.csv is its message, without the
exception's class name.

Time budget: one page's checks (an Agg rendering at 72 dpi, then the
boxes) under 10 s, asserted per page.
"""
from __future__ import annotations

import json
import time

import pytest
from matplotlib.colors import to_rgb
from matplotlib.text import Text

from bayescal.report import batch as rb
from tests.figures import layout_faults
from tests.test_cli_batch_flags import REF_A, REF_B, _row

#: Seconds one page's rendering and checks may take.
BUDGET_S = 10.0
REF_C = "XX.B.00.BH1;XX.B.00.BH2"
REF_D = "XX.A.30.BH1;XX.A.30.BH2"


def _gain_row(day, az, gain, label):
    """Station XX.B's BH1 against one reference, gain fitted (nominal 750)."""
    return {**_row(day, az, 0.3, REF_C, label=label, channel="XX.B.10.BH1"), "station": "XX.B",
            "gain": gain, "gain_lo95": gain - 3.0, "gain_hi95": gain + 3.0,
            "nominal_gain": 750.0}


#: Station XX.A, a huddle: the SUT's BH1 and BH2 against three references
#: (six pairs, the legend beside the panels) over two days; BH1 against
#: reference B 5 deg off nominal on day 1 and 8 deg on day 2 (a change of
#: +3.00 deg), every other pair within 2 deg of nominal. Station XX.B: gain
#: 750 then 780 (+4.00 % of nominal, beyond 2 % and its +-0.4 % interval: off
#: nominal and changed). One item failed with a long message.
DAYS = ("2026-01-01", "2026-01-02")
ROWS = [_row(DAYS[0], 0.0, 0.2, REF_A), _row(DAYS[0], 5.0, 0.2, REF_B),
        _row(DAYS[1], 0.1, 0.2, REF_A), _row(DAYS[1], 8.0, 0.2, REF_B),
        *[_row(d, 1.0, 0.2, REF_D) for d in DAYS],
        *[{**_row(d, 90.0 + k, 0.2, r, channel="XX.A.10.BH2"), "nominal_azimuth": 90.0}
          for d in DAYS for k, r in enumerate((REF_A, REF_B, REF_D))],
        _gain_row("2026-01-01", 0.4, 750.0, "b1"), _gain_row("2026-01-02", 0.5, 780.0, "b2"),
        {"label": "c1", "station": "XX.C", "day": "2026-01-01",
         "error": "/data/archive/XX/C/BHZ.D/XX.C.10.BHZ.D.2026.001: file not found; the plan's "
                  "row 7 names it as the SUT's vertical channel of the pair c1"}]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The report's pages (png path or None, figure), as write_report hands
    them to layout.write_pages, each checked in the report's style."""
    from bayescal.report import layout

    out = tmp_path_factory.mktemp("batch")
    rb._write_csv(str(out / "results.csv"), rb.COLUMNS, ROWS)
    (out / "2026-01-02-20").mkdir()           # one item's folder: its 68 % interval
    (out / "2026-01-02-20" / "result.json").write_text(json.dumps(
        {"channels": {"XX.A.10.BH1": {"azimuth_deg": {"median": 8.0, "ci68": [7.9, 8.1]}}}}))
    got = []

    def keep(figs, pdf_path, **kw):
        for png, fig in figs:
            t0 = time.perf_counter()
            got.append((png, fig, layout_faults(fig), time.perf_counter() - t0))
        return []

    mp = pytest.MonkeyPatch()
    mp.setattr(layout, "write_pages", keep)
    try:
        rb.write_report(str(out / "results.csv"), str(out))
    finally:
        mp.undo()
    return got


def test_batch_pages_lay_out_cleanly(pages):
    """No layout fault on the summary page nor on the time page (XX.A's
    six pairs: its legend beside the row, not over a curve)."""
    assert len(pages) == 2                     # the summary page, one page of two stations
    for k, (_, _, faults, spent) in enumerate(pages):
        assert faults == [], (k, faults)
        assert spent < BUDGET_S, (k, spent)


def test_batch_pages_draw_in_greys(pages):
    """Every line and marker of the time page in a grey (red, green and
    blue equal), as the fit report draws."""
    from matplotlib.lines import Line2D

    fig = pages[1][1]
    colours = {to_rgb(c) for ln in fig.findobj(Line2D) for c in
               (ln.get_color(), ln.get_markeredgecolor(), ln.get_markerfacecolor())
               if c not in ("none", "None")}
    assert colours and all(r == g == b for r, g, b in colours), colours


def test_flags_table_is_the_fit_reports_with_the_flagged_numbers(pages):
    """The summary page's flags in layout.summary_table's columns: pair B
    off nominal by +5.00 and +8.00 deg, changed by +3.00 deg, XX.B's gain
    +4.00 % off nominal and changed by +4.00 %; the 68 % interval of the
    item whose folder holds a result.json, '-' for the others; the failed
    item's message on the page."""
    fig = pages[0][1]
    tables = [t for ax in fig.axes for t in ax.tables]
    assert len(tables) == 1
    cells = tables[0].get_celld()
    n_rows = 1 + max(i for i, _ in cells)
    text = [[cells[i, j].get_text().get_text() for j in range(8)] for i in range(n_rows)]
    assert text[0] == ["channel", "quantity", "median", "68 % interval", "95 % interval",
                       "nominal", "deviation", "note"]
    got = {(" ".join(r[0].split()), r[1], r[6], " ".join(r[7].split())) for r in text[1:]}
    pair_b, gain = "XX.A.10.BH1 vs 20.BH1,20.BH2", "XX.B.10.BH1 vs 00.BH1,00.BH2"
    ci68 = {r[3] for r in text[1:]}
    assert ci68 == {"[7.90, 8.10]", "-"} and [r[3] for r in text].count("[7.90, 8.10]") == 2
    assert got == {
        (pair_b, "azimuth (deg)", "+5.00", "off nominal on 2026-01-01"),
        (pair_b, "azimuth (deg)", "+8.00", "off nominal on 2026-01-02"),
        (pair_b, "azimuth (deg)", "+8.00",
         "changed by +3.00 deg [+2.72, +3.28] from 2026-01-01 to 2026-01-02"),
        (gain, "gain (stage-1 units per m/s)", "+4.00 %", "off nominal on 2026-01-02"),
        (gain, "gain (stage-1 units per m/s)", "+4.00 %",        # +-hypot(0.4, 0.4) %
         "changed by +4.00 % [+3.43, +4.57] from 2026-01-01 to 2026-01-02")}, got
    words = " ".join(" ".join(t.get_text() for t in fig.findobj(Text)).split())
    assert "c1: /data/archive/XX/C/BHZ.D/XX.C.10.BHZ.D.2026.001: file not found" in words


def test_error_column_holds_the_message_only(tmp_path):
    """record_error writes the exception's message (its first line) into
    error.json and so into results.csv; its class name only when it has no
    message."""
    from bayescal.errors import InputError
    from bayescal.network.batch import record_error

    item = {"label": "x", "network": "XX", "station": "X", "day": "2026-01-01"}
    record_error(item, str(tmp_path), InputError("x.mseed: file not found\n  details"))
    assert json.loads((tmp_path / "x" / "error.json").read_text())["error"] == \
        "x.mseed: file not found"
    rows = rb.read_results(rb.results_table([item], str(tmp_path)))
    assert [r["error"] for r in rows] == ["x.mseed: file not found"]
    assert record_error({"label": "y"}, str(tmp_path), ValueError())["error"] == "ValueError"
