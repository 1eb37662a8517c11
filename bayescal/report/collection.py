"""Python's cyclic garbage collection paused while a report is drawn.

Drawing a report makes tens of thousands of small objects (matplotlib's
artists, transforms and paths, most of them in reference cycles with their
figure) and imports matplotlib, whose modules are hundreds of thousands
more: the collector's automatic passes walk them all again and again, a
tenth of a default report's time (docs/validation/speed.md, "Reports
against their fits"), and free next to nothing until the figures are
closed. Paused for the report, the collector resumes afterwards and frees
the closed figures' cycles in its next pass.
"""
from __future__ import annotations

import contextlib
import gc


@contextlib.contextmanager
def collection_paused():
    """Pause the automatic cyclic garbage collection (:func:`gc.disable`)
    for the duration of the block or of the decorated function, and resume
    it afterwards if it ran before (also when the block raises). Reference
    counting frees objects without cycles as always.

    Examples
    --------
    >>> import gc
    >>> with collection_paused():
    ...     gc.isenabled()
    False
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
