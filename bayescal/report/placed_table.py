"""A report's table with its cells placed once, when it is made.

matplotlib's :class:`~matplotlib.table.Table` places its cells each time it
is drawn: it measures every cell's extent to find the grid's box, scales
the cells to the table's box, and measures every cell again to place its
text, the extent of each cell computed from its path with numpy (two
measurements per cell of a page's table cost more than drawing its text).
A report's table fills its axes with columns and rows whose sizes are
known when it is made (:func:`bayescal.report.layout.fit_columns`), so
:class:`PlacedTable` places the cells then and draws each cell's rectangle
and text where matplotlib's layout puts them, without measuring: the same
cells (``get_celld``), the same drawing.
"""
from __future__ import annotations

import numpy as np
from matplotlib.patches import Patch
from matplotlib.table import Table


class PlacedTable(Table):
    """A :class:`~matplotlib.table.Table` of ``ax`` filling the axes (its
    ``bbox`` is the axes), whose cells are placed by :func:`placed_table`."""

    def draw(self, renderer):
        """Draw each cell (in matplotlib's order: by row, then column): its
        rectangle, then its text in the cell's place for its alignment
        (``Cell.PAD`` of the cell's width from its side, centred
        vertically), from the cells' positions in the axes."""
        if not self.get_visible():
            return
        renderer.open_group("table", gid=self.get_gid())
        cells = self.get_celld()
        keys = sorted(cells)
        corners = np.array([[(c.get_x(), c.get_y()), (c.get_x() + c.get_width(),
                                                      c.get_y() + c.get_height())]
                            for c in (cells[k] for k in keys)], float)
        shown = self.get_transform().transform(corners.reshape(-1, 2)).reshape(-1, 2, 2)
        for key, ((x0, y0), (x1, y1)) in zip(keys, shown):
            cell = cells[key]
            if not cell.get_visible():
                continue
            Patch.draw(cell, renderer)
            text = cell.get_text()
            side = {"left": cell.PAD, "center": 0.5}.get(text.get_horizontalalignment(),
                                                         1 - cell.PAD)
            text.set_position((x0 + (x1 - x0) * side, y0 + (y1 - y0) / 2))
            text.draw(renderer)
        renderer.close_group("table")
        self.stale = False


def placed_table(ax, rows, widths, heights, fontsize, *, loc="left", edges="horizontal"):
    """A :class:`PlacedTable` filling ``ax``: ``rows`` of strings (the
    column labels first), columns of ``widths`` and rows of ``heights``
    (fractions of the axes, each summing to 1), text aligned ``loc`` at
    ``fontsize`` points, cells white with black ``edges`` (matplotlib's
    ``Table.edges``), as ``ax.table(..., bbox=[0, 0, 1, 1])`` lays them
    out. Returns the table, added to ``ax``."""
    tab = PlacedTable(ax, "upper left", bbox=[0, 0, 1, 1])
    tab.edges = edges
    lefts = np.concatenate([[0.0], np.cumsum(widths)[:-1]])
    # rows stacked from the last (at the bottom) up, as matplotlib stacks them
    bottoms = np.concatenate([np.cumsum(heights[::-1])[::-1][1:], [0.0]])
    for i, row in enumerate(rows):
        for j, text in enumerate(row):
            cell = tab.add_cell(i, j, width=widths[j], height=heights[i], text=text,
                                facecolor="w", loc=loc)
            cell.set_xy((lefts[j], bottoms[i]))
    tab.auto_set_font_size(False)
    tab.set_fontsize(fontsize)
    ax.add_table(tab)
    return tab
