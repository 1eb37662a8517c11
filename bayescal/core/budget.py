"""Work budgets: how much a stage may compute, counted in work, not seconds.

A stage that stops on a clock (a search for effects, a chain's length) gives
answers that depend on the machine's speed and load. A :class:`Budget`
counts the stage's work instead, in **model evaluations**: one evaluation
of a pair model's residual at one parameter vector (an ensemble step of 40
walkers is 40; a forward-difference Jacobian of ``n`` parameters is
``n + 1``). The pair model counts its own evaluations
(:meth:`bayescal.core.model.likelihood.Model.plain_residual_blocks` calls
:func:`charge`) into every budget made active with :meth:`Budget.active`,
so the same seed spends the same work, and stops at the same place, on any
machine.

A wall-clock limit stays only as a safety net (``time_limit_s``, far above
the budget's normal cost): when it, not the work, ends a stage, the budget
says so (:meth:`Budget.note`), since that stage's answer then depends on the
machine.
"""
from __future__ import annotations

import contextlib
import contextvars
import time

#: The work unit of every budget.
UNIT = "model evaluations"
#: The work budgets of a pair fit's stages (:func:`bayescal.core.fit.run.fit_spectra`):
#: the least squares, the mode search and the sampler, whose ``max_steps``,
#: when not given, is what ``SAMPLE_WORK`` leaves over its walkers after the
#: burn-in (7348 steps at 40 walkers, 4848 at 60: about twice the longest
#: chain that met the convergence rule on the speed benchmarks and the
#: awkward inputs, 2562 steps at 60 walkers). The least squares and the mode
#: search use 408 and 4504 on `period_3x_all` (docs/validation/speed.md,
#: "Awkward inputs"). Together about 30-60 s of a two-core computer's work;
#: the criticism's budget is its own (``--diagnose-budget``).
LEAST_SQUARES_WORK = 30_000
MODE_SEARCH_WORK = 30_000
SAMPLE_WORK = 300_000

_ACTIVE = contextvars.ContextVar("bayescal_budgets", default=())


def charge(n):
    """Count ``n`` units of work into every active budget (nothing when none
    is); a budget's ``listener`` (a progress bar) is told its new total."""
    for b in _ACTIVE.get():
        b.used += int(n)
        if b.listener is not None:
            b.listener(b.used)


class Budget:
    """The work a stage may do: ``limit`` :data:`UNIT`, and a wall-clock
    safety net of ``time_limit_s`` seconds (None: none) from its creation.

    ``used`` counts the work charged while it is active; :meth:`spent` says
    when the stage should stop and records why (``ended_by``: ``"work"`` or
    ``"time"``). ``helps``: what the user can do when it ends the stage (an
    option, a narrower band), said in :meth:`note`."""

    def __init__(self, stage, limit, time_limit_s=None, helps=None):
        self.stage, self.limit = str(stage), int(limit)
        self.time_limit_s = None if time_limit_s is None else float(time_limit_s)
        self.helps = helps
        self.used = 0
        self.ended_by = None
        self.listener = None
        self._t0 = time.monotonic()

    @property
    def remaining(self):
        """Work left (0 once spent)."""
        return max(self.limit - self.used, 0)

    def elapsed_s(self):
        """Seconds since the budget was made."""
        return time.monotonic() - self._t0

    def out_of_time(self):
        """True once the safety net's time has passed (and records it)."""
        if self.time_limit_s is not None and self.elapsed_s() > self.time_limit_s:
            self.ended_by = self.ended_by or "time"
            return True
        return False

    def spent(self):
        """True once the work is used up, or the safety net's time has
        passed; ``ended_by`` records which came first."""
        if self.used >= self.limit:
            self.ended_by = self.ended_by or "work"
            return True
        return self.out_of_time()

    @contextlib.contextmanager
    def active(self):
        """Within this context the work :func:`charge` counts goes to this
        budget too (budgets nest: an inner stage's work is also the outer's;
        a budget made active again inside its own context counts once)."""
        active = _ACTIVE.get()
        token = _ACTIVE.set(active if self in active else active + (self,))
        try:
            yield self
        finally:
            _ACTIVE.reset(token)

    def check(self):
        """Raise :class:`~bayescal.errors.BudgetSpent` once :meth:`spent`
        (for a stage that ends from inside its computation)."""
        if self.spent():
            from ..errors import BudgetSpent
            raise BudgetSpent(self.note())

    def note(self):
        """One line naming the stage and what ended it ('' while it has not
        ended), and what helps when ``helps`` is set."""
        helps = f"; {self.helps}" if self.helps else ""
        if self.ended_by == "time":
            return (f"{self.stage}: ended by its time limit ({self.time_limit_s:g} s, a safety "
                    f"net), not by its work budget ({self.used} of {self.limit} {UNIT} used): "
                    f"this result depends on the machine's speed{helps}")
        if self.ended_by == "work":
            return f"{self.stage}: ended by its work budget ({self.limit} {UNIT}){helps}"
        return ""

    def summary(self):
        """JSON-safe: stage, unit, limit, used, the time limit and what ended it."""
        return {"stage": self.stage, "unit": UNIT, "limit": self.limit, "used": self.used,
                "time_limit_s": self.time_limit_s, "ended_by": self.ended_by}
