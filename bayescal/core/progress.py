"""Where a fit's time goes, said on stderr while it runs.

Each stage of a fit (the least-squares search, the mode search, each phase
of the sampler, the criticism's candidates) reports through this module:
without a terminal (stderr a file or a pipe, as in a batch's log) one line
per stage, or per check of the sampler's convergence rule; on a terminal a
bar while the stage runs, then the same line. Nothing is said while
progress is off.

Progress is on inside :func:`shown` (``bayescal fit`` turns it on unless
``--quiet``; :func:`bayescal.calibrate` with ``progress=True``). The setting
is a context variable, so a stage deep in the package reads it without it
being handed down, and the criticism's log (:func:`line`) goes to the same
channel. Errors and the result's summary do not pass through here.
"""
from __future__ import annotations

import contextlib
import contextvars
import sys
import time

_SHOWN = contextvars.ContextVar("bayescal_progress", default=False)


@contextlib.contextmanager
def shown(enabled=True):
    """Within this context progress is said (``enabled`` True) or not."""
    token = _SHOWN.set(bool(enabled))
    try:
        yield
    finally:
        _SHOWN.reset(token)


def enabled():
    """True where progress is said (inside ``shown(True)``)."""
    return _SHOWN.get()


def terminal():
    """True when stderr is a terminal (a bar can be drawn)."""
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def line(text):
    """Say one line of progress on stderr (nothing while progress is off)."""
    if _SHOWN.get():
        print(text, file=sys.stderr, flush=True)


def logger(prefix):
    """A log callback (one line of text per call, as the criticism's search
    logs) whose lines are said as progress after ``prefix``; None while
    progress is off."""
    if not _SHOWN.get():
        return None
    return lambda text: line(f"{prefix}: {text.strip()}")


class Stage:
    """A stage in progress: its name, its :class:`~bayescal.core.budget.Budget`
    (or None), when it started and, on a terminal, its bar (the work used of
    the budget's). :meth:`done` says its line."""

    def __init__(self, name, budget=None):
        self.name, self.budget = name, budget
        self.t0 = time.monotonic()
        self.bar = None
        self.result = ""
        if _SHOWN.get() and terminal() and budget is not None:
            from tqdm.auto import tqdm
            self.bar = tqdm(total=budget.limit, unit="eval", desc=name, leave=False)
            budget.listener = self._update

    def _update(self, used):
        self.bar.update(min(used, self.bar.total) - self.bar.n)

    def done(self):
        """Close the bar and say the stage's line: its result, its work
        and its time; a spent budget's note."""
        if self.bar is not None:
            self.bar.close()
            self.budget.listener = None
        work = f"{self.budget.used} model evaluations, " if self.budget is not None else ""
        sep = ": " if self.result else ""
        line(f"{self.name}{sep}{self.result} ({work}{time.monotonic() - self.t0:.1f} s)")


@contextlib.contextmanager
def stage(name, budget=None):
    """Run a stage: yields a :class:`Stage` (set its ``result``, the words
    its line ends with); its line is said when the context ends."""
    s = Stage(name, budget)
    try:
        yield s
    finally:
        s.done()
