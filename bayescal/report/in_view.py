"""Ticks made only where they are drawn.

matplotlib makes a tick (five artists: two tick marks, the grid line, two
labels) for every location its tick locator gives, and the log and "nice
number" locators give locations beyond the view on each side, which it
then does not draw: a third of the ticks of a fit's report. :class:`InView`
gives the locations in the view alone, through matplotlib's extension
point for tick placement (a :class:`matplotlib.ticker.Locator`), so that
the page drawn is the same with fewer objects made and measured.
"""
from __future__ import annotations

import numpy as np
from matplotlib.ticker import Locator, LogLocator, MaxNLocator

#: Tolerance, as a fraction of the axis's span in its scale's coordinates,
#: within which a location at the edge of the view counts as in it
#: (matplotlib draws a tick within 1e-10 of the span; a looser bound keeps
#: every tick it draws).
IN_VIEW_TOLERANCE = 1e-6


class InView(Locator):
    """The locations the locator ``base`` gives that lie in the axis's
    view. Autoscaling asks ``base`` (:meth:`nonsingular`,
    :meth:`view_limits`), so the axis's limits are ``base``'s."""

    def __init__(self, base):
        """Wrap the locator ``base``."""
        self.base = base

    def set_axis(self, axis):
        """Attach this locator and ``base`` to ``axis``."""
        super().set_axis(axis)
        self.base.set_axis(axis)

    def __call__(self):
        """``base``'s locations within the view (and any the scale cannot
        place), in its order."""
        locs = np.asarray(self.base(), float)
        lo, hi = sorted(self.axis.get_view_interval())
        scale = self.axis.get_transform()
        with np.errstate(invalid="ignore", divide="ignore"):
            (lo, hi), pos = scale.transform([lo, hi]), scale.transform(locs)
        tol = IN_VIEW_TOLERANCE * abs(hi - lo)
        # a location the scale cannot place (NaN) is kept: matplotlib decides
        return locs[~((pos < lo - tol) | (pos > hi + tol))]

    def tick_values(self, vmin, vmax):
        """``base``'s locations for ``[vmin, vmax]``, all of them."""
        return self.base.tick_values(vmin, vmax)

    def nonsingular(self, v0, v1):
        """``base``'s answer (autoscaling)."""
        return self.base.nonsingular(v0, v1)

    def view_limits(self, vmin, vmax):
        """``base``'s answer (autoscaling)."""
        return self.base.view_limits(vmin, vmax)


def ticks_in_view(fig):
    """Give every axis of ``fig`` (a Figure or SubFigure, its subfigures
    too) whose major ticks a log or "nice number" locator places
    (matplotlib's ``LogLocator``, ``MaxNLocator``, ``AutoLocator``) only
    the ticks within its view (:class:`InView`): the page drawn is the
    same. Call it when the figure is complete, before drawing it."""
    for ax in fig.axes:
        for which in (ax.xaxis, ax.yaxis):
            loc = which.get_major_locator()
            if isinstance(loc, (LogLocator, MaxNLocator)):
                which.set_major_locator(InView(loc))
    for sub in fig.subfigs:
        ticks_in_view(sub)
