"""What a report saves in drawing without changing a page: the ticks
matplotlib would make beyond an axis's view and not draw
(:func:`bayescal.report.in_view.ticks_in_view`), tables whose cells are
placed once (:mod:`bayescal.report.placed_table`), and Python's cyclic
garbage collection paused while a report is drawn
(:mod:`bayescal.report.collection`)."""
from __future__ import annotations

import gc
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from bayescal.errors import InputError
from bayescal.report.axes import log_ticks
from bayescal.report.in_view import ticks_in_view
from bayescal.report.collection import collection_paused
from bayescal.report.layout import write_pages

#: A 0.03-1 Hz band on a log axis, labelled 1, 2, 5 x 10^n (1.5 decades):
#: in view 0.05, 0.1, 0.2, 0.5, 1 (matplotlib's locator adds a decade or so
#: on each side).
LOG_IN_VIEW = [0.05, 0.1, 0.2, 0.5, 1.0]
#: A linear axis over 0.5-9.5: matplotlib's automatic ticks 0, 2, ..., 10,
#: of which 2, 4, 6, 8 in view.
LINEAR_IN_VIEW = [2.0, 4.0, 6.0, 8.0]


def _figure():
    """A page's axes: log frequency against a linear quantity, with a legend
    and a grid (the report's style)."""
    fig = Figure(figsize=(4, 3), dpi=90)
    ax = fig.add_subplot()
    f = np.geomspace(0.03, 1.0, 60)
    ax.plot(f, 0.5 + 9.0 * (f - 0.03) / 0.97, label="curve")
    ax.set_xscale("log")
    log_ticks(ax, 0.03, 1.0)
    ax.set_xlim(0.03, 1.0)
    ax.set_ylim(0.5, 9.5)
    ax.grid(True)
    ax.legend()
    return fig, ax


def _pixels(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


def test_only_the_ticks_in_view_are_made_and_the_page_is_the_same():
    plain, ax0 = _figure()
    trimmed, ax1 = _figure()
    ticks_in_view(trimmed)
    assert np.array_equal(_pixels(plain), _pixels(trimmed))
    untrimmed = ax0.xaxis.get_majorticklocs()
    assert min(untrimmed) < 0.03 and max(untrimmed) > 1.0
    np.testing.assert_allclose(ax1.xaxis.get_majorticklocs(), LOG_IN_VIEW)
    np.testing.assert_allclose(ax1.yaxis.get_majorticklocs(), LINEAR_IN_VIEW)
    # a tick object per location given: those beyond the view are not made
    assert len(ax1.xaxis.majorTicks) == len(LOG_IN_VIEW)
    assert len(ax1.yaxis.majorTicks) == len(LINEAR_IN_VIEW)
    assert len(ax0.xaxis.majorTicks) == len(untrimmed)


def test_autoscaled_limits_are_the_locators():
    """Limits left to autoscaling are those without the trimming (the
    base locator's ``nonsingular`` and ``view_limits``), also for data that
    are one value (a singular range)."""
    def limits(trim):
        fig = Figure()
        ax = fig.add_subplot()
        ax.plot([1.0, 1.0], [3.0, 3.0])
        if trim:
            ticks_in_view(fig)
        FigureCanvasAgg(fig).draw()
        return ax.get_xlim(), ax.get_ylim(), ax.yaxis.get_majorticklocs()
    (x0, y0, t0), (x1, y1, t1) = limits(False), limits(True)
    assert x0 == x1 and y0 == y1
    lo, hi = y1
    np.testing.assert_array_equal(t1, [t for t in t0 if lo <= t <= hi])


def test_written_pages_have_only_their_ticks_in_view(tmp_path):
    fig, ax = _figure()
    write_pages([(None, fig)], str(tmp_path / "page.pdf"))
    np.testing.assert_allclose(ax.xaxis.get_majorticklocs(), LOG_IN_VIEW)
    np.testing.assert_allclose(ax.yaxis.get_majorticklocs(), LINEAR_IN_VIEW)


def test_collection_paused_and_resumed():
    assert gc.isenabled()
    with collection_paused():
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(ValueError), collection_paused():
        raise ValueError
    assert gc.isenabled()
    gc.disable()
    try:
        with collection_paused():
            pass
        assert not gc.isenabled()          # left as it was
    finally:
        gc.enable()


def test_a_fit_report_is_drawn_with_the_collector_paused(monkeypatch):
    """``write_report`` and ``bayescal report`` run with the collector
    paused, and resume it, also when the folder cannot be read."""
    from bayescal.cli import report as cli_report
    from bayescal.report import fit

    seen = []

    def unreadable(folder):
        seen.append(gc.isenabled())
        raise InputError(f"{folder}: unreadable")

    monkeypatch.setattr(fit, "load_result", unreadable)
    with pytest.raises(InputError):
        fit.write_report("nowhere")
    args = SimpleNamespace(folder="nowhere", threshold=2.0, truth=None, paper="a4", png=False,
                           full=False)
    with pytest.raises(InputError):
        cli_report.run(args)
    assert seen == [False, False]
    assert gc.isenabled()


def test_a_placed_table_is_drawn_as_matplotlibs_table():
    """A table whose cells are placed once (``placed_table``) draws the same
    pixels as matplotlib's ``ax.table`` laying out the same cells (columns
    of given widths, rows of given heights, the header first, a wrapped
    note), its cells and texts where matplotlib places them."""
    from bayescal.report.placed_table import placed_table

    rows = [["channel", "quantity", "median", "note"],
            ["XX.SIM.10.BH1", "azimuth (deg)", "3.25", ""],
            ["XX.SIM.10.BHZ", "tilt (deg)", "0.57", "undefined\n(near vertical)"],
            ["XX.SIM.10.BH2", "gain", "756.3", "-"]]
    widths = [0.3, 0.3, 0.15, 0.25]
    heights = [0.2, 0.2, 0.4, 0.2]

    def page(place):
        fig = Figure(figsize=(5, 2), dpi=90)
        ax = fig.add_axes([0.05, 0.1, 0.9, 0.8])
        ax.axis("off")
        if place:
            tab = placed_table(ax, rows, widths, heights, 6.5)
        else:
            tab = ax.table(cellText=rows[1:], colLabels=rows[0], loc="upper left",
                           cellLoc="left", colLoc="left", edges="horizontal",
                           bbox=[0, 0, 1, 1])
            tab.auto_set_font_size(False)
            tab.set_fontsize(6.5)
            for (i, j), cell in tab.get_celld().items():
                cell.set_width(widths[j])
                cell.set_height(heights[i])
        return fig, tab

    (fig0, tab0), (fig1, tab1) = page(False), page(True)
    assert np.array_equal(_pixels(fig0), _pixels(fig1))
    r0, r1 = fig0.canvas.get_renderer(), fig1.canvas.get_renderer()
    cells0, cells1 = tab0.get_celld(), tab1.get_celld()
    assert sorted(cells0) == sorted(cells1)
    for key, cell in cells1.items():
        np.testing.assert_allclose(cell.get_window_extent(r1).extents,
                                   cells0[key].get_window_extent(r0).extents, atol=1e-9)
        np.testing.assert_allclose(cell.get_text().get_position(),
                                   cells0[key].get_text().get_position(), atol=1e-9)
        assert cell.get_text().get_text() == cells0[key].get_text().get_text()


def test_a_commands_collection_is_left_to_its_exit():
    """``bayescal report``'s collection: paused while it runs and resumed
    after, nothing kept frozen in the process, and at the process's exit the
    collector passes over nothing: a reference cycle left then is not
    collected (its finaliser does not run), as it is in a plain process."""
    import subprocess
    import sys
    from pathlib import Path

    from bayescal.report.collection import collection_left_to_exit

    import atexit
    try:
        with collection_left_to_exit():
            assert not gc.isenabled()
        assert gc.isenabled() and gc.get_freeze_count() == 0
        with pytest.raises(ValueError), collection_left_to_exit():
            raise ValueError
        assert gc.isenabled()
    finally:
        atexit.unregister(gc.freeze)    # this test process's exit stays as it was
    code = ("class Cycle:\n"
            "    def __del__(self): print('collected')\n"
            "{}\n"
            "c = Cycle(); c.me = c; del c\n")
    use = ("from bayescal.report.collection import collection_left_to_exit\n"
           "with collection_left_to_exit(): pass")

    def run(prefix):
        return subprocess.run([sys.executable, "-c", code.format(prefix)], capture_output=True,
                              text=True, check=True,
                              cwd=Path(__file__).resolve().parents[1]).stdout
    assert run("pass") == "collected\n"
    assert run(use) == ""


def test_only_the_console_command_leaves_its_collection_to_exit(monkeypatch, tmp_path):
    """``bayescal.cli.main([...])`` called from Python draws with the
    collection paused and resumed only; the console command (``main()``,
    the process's own arguments) also leaves it to the process's exit."""
    import contextlib
    import sys

    from bayescal import cli
    from bayescal.cli import report as cli_report

    used = []

    def recorder(name):
        @contextlib.contextmanager
        def ctx():
            used.append(name)
            yield
        return ctx

    monkeypatch.setattr(cli_report, "collection_left_to_exit", recorder("exit"))
    monkeypatch.setattr(cli_report, "collection_paused", recorder("paused"))
    missing = str(tmp_path / "nowhere")
    assert cli.main(["report", missing]) == 2
    monkeypatch.setattr(sys, "argv", ["bayescal", "report", missing])
    assert cli.main() == 2
    assert used == ["paused", "exit"]
