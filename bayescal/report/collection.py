"""Python's cyclic garbage collection paused while a report is drawn.

Drawing a report makes tens of thousands of small objects (matplotlib's
artists, transforms and paths, most of them in reference cycles with their
figure) and imports matplotlib, whose modules are hundreds of thousands
more: each of the collector's automatic passes walks them all and
frees next to nothing until the figures are closed
(docs/validation/speed.md, "Reports against their fits").
:func:`collection_paused` pauses it while a report is drawn; the collector
resumes afterwards and frees the closed figures' cycles at once.
:func:`collection_left_to_exit` is for a command whose process ends after
it (the ``bayescal report`` command): there the pass after the report, and the
interpreter's passes at its exit over every object alive (matplotlib's
modules among them), would cost most of what the pause saves, to free
memory that exiting frees anyway.
"""
from __future__ import annotations

import atexit
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


@contextlib.contextmanager
def collection_left_to_exit():
    """The collection paused for a command whose process ends after it
    (:func:`collection_paused`), and afterwards left to the process's end:
    the objects made meanwhile join the oldest generation without a pass
    over them (:func:`gc.freeze` then :func:`gc.unfreeze`; a caller that
    goes on running frees their cycles at its next full collection), and
    when the process exits the collector skips every object then alive
    (:func:`gc.freeze` run at exit, :mod:`atexit`): exiting frees them.
    The collection resumes afterwards if it ran before, also when the block
    raises."""
    with collection_paused():
        try:
            yield
        finally:
            gc.freeze()
            gc.unfreeze()
            atexit.unregister(gc.freeze)    # once, however many commands a process runs
            atexit.register(gc.freeze)
