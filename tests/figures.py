"""Layout faults of a matplotlib figure, found from matplotlib's own tight
bounding boxes after one Agg rendering at the figure's size (no bayescal
import here):

* text off the page: a figure text, or an axes' tight box (its tick labels,
  axis labels, title, texts, legend and table), reaching outside the figure;
* a figure text over an axes' plotting area (axes drawn without their
  frame, as tables, are left out);
* a table cell's text wider or taller than its cell (it runs into the next
  column or row);
* a legend over a curve: a point of a data line drawn inside the axes
  (vertices and 8 points along each segment) inside the legend's box;
  reference lines spanning the axes (``axhline``, ``axvline``: not in data
  coordinates) are left out;
* a legend entry whose curve has no point inside the axes (named in the
  legend, not drawn).
"""
from __future__ import annotations

import numpy as np

#: Slack in pixels (at 72 dpi) for rounding in the renderer.
SLACK = 1.0
DPI = 72


def _render(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig.set_dpi(DPI)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _outside(box, frame):
    return (box.x0 < frame.x0 - SLACK or box.y0 < frame.y0 - SLACK
            or box.x1 > frame.x1 + SLACK or box.y1 > frame.y1 + SLACK)


def _all_axes(fig):
    return [ax for ax in fig.get_axes() if ax.get_visible()]


def _texts_off_page(fig, r):
    faults = []
    from matplotlib.text import Text

    ticks = {id(t) for ax in fig.findobj(lambda a: hasattr(a, "get_major_ticks"))
             for tick in ax.get_major_ticks() + ax.get_minor_ticks()
             for t in (tick.label1, tick.label2)}
    for t in fig.findobj(Text):
        if (t.axes is not None or id(t) in ticks or not t.get_visible()
                or not t.get_text().strip()):
            continue                          # an axes' text: in its tight box below
        box = t.get_window_extent(r)
        if _outside(box, fig.bbox):
            faults.append(f"text off the page: {t.get_text()[:60]!r}")
        for ax in _all_axes(fig):
            if ax.axison and box.overlaps(ax.bbox):
                faults.append(f"text over the axes {ax.get_title()!r}: {t.get_text()[:60]!r}")
    for ax in _all_axes(fig):
        box = ax.get_tightbbox(r)
        if box is not None and _outside(box, fig.bbox):
            faults.append(f"axes off the page: {ax.get_title() or ax.get_xlabel()!r}")
    return faults


def _table_spills(fig, r):
    faults = []
    for ax in _all_axes(fig):
        for tab in ax.tables:
            for key, cell in tab.get_celld().items():
                text = cell.get_text()
                if not text.get_text().strip():
                    continue
                t, c = text.get_window_extent(r), cell.get_window_extent(r)
                if t.width > c.width + SLACK or t.height > c.height + SLACK \
                        or t.x1 > c.x1 + SLACK or t.x0 < c.x0 - SLACK:
                    faults.append(f"table text outside its cell {key}: {text.get_text()[:40]!r}")
    return faults


def _curve_points(ax, line):
    xy = np.asarray(line.get_xydata(), float)
    if line.get_transform() != ax.transData or len(xy) == 0:
        return np.zeros((0, 2))
    pts = line.get_transform().transform(xy)
    if line.get_linestyle() not in ("None", "none", "", " ") and len(pts) > 1:
        t = np.linspace(0.0, 1.0, 9)[:, None, None]
        pts = (pts[:-1][None] * (1 - t) + pts[1:][None] * t).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    b = ax.bbox
    inside = ((pts[:, 0] >= b.x0) & (pts[:, 0] <= b.x1) & (pts[:, 1] >= b.y0)
              & (pts[:, 1] <= b.y1))
    return pts[inside]


def _legend_faults(fig, r):
    faults = []
    legends = [(ax, ax.get_legend()) for ax in _all_axes(fig) if ax.get_legend()]
    legends += [(ax, leg) for leg in fig.legends for ax in _all_axes(fig)]
    for ax, leg in legends:
        box = leg.get_window_extent(r)
        for line in ax.get_lines():
            if not line.get_visible():
                continue
            pts = _curve_points(ax, line)
            hit = ((pts[:, 0] > box.x0 + SLACK) & (pts[:, 0] < box.x1 - SLACK)
                   & (pts[:, 1] > box.y0 + SLACK) & (pts[:, 1] < box.y1 - SLACK))
            if hit.any():
                faults.append(f"legend over the curve {line.get_label()!r}")
        if leg in fig.legends:
            continue
        for handle, label in zip(*ax.get_legend_handles_labels()):
            if hasattr(handle, "get_xydata") and handle.get_transform() == ax.transData \
                    and len(_curve_points(ax, handle)) == 0:
                faults.append(f"in the legend, not on the axes: {label!r}")
    return faults


def layout_faults(fig):
    """Every layout fault of ``fig`` (list of strings; empty when none),
    from one Agg rendering at the figure's size."""
    r = _render(fig)
    return _texts_off_page(fig, r) + _table_spills(fig, r) + _legend_faults(fig, r)
