"""Every exception and warning bayescal raises, in one module (a leaf: imports
nothing of bayescal, so every layer may import it).

Errors a user can fix end a ``bayescal`` command with one line and exit code
2 (:func:`bayescal.cli.main`): :class:`InputError`, :class:`SpectraError`,
:class:`FitError` and :class:`ResponseError`. The warnings leave the result
standing and say what to read with care; a script may turn one into an
error with :func:`warnings.simplefilter`.
"""


class InputError(ValueError):
    """Bad input data or metadata; the message names the source and problem."""


class InputWarning(UserWarning):
    """Suspicious input (clipping, NaN samples) that does not stop the fit."""


class SpectraError(ValueError):
    """The data cannot give the spectra asked for (too short, empty band...)."""


class ResponseError(ValueError):
    """A response cannot be used as asked (missing stage, wrong type...)."""


class FitError(RuntimeError):
    """The fit cannot proceed (nothing estimable, optimizer failure...)."""


class NotHandled(Exception):
    """A response the numpy evaluation (:mod:`bayescal.core.response.evalresp`)
    does not evaluate: ObsPy's evalresp is asked instead."""


class ModelMisfitWarning(UserWarning):
    """The fit's model check failed: the recordings differ from the model by
    more than its noise allows (:func:`bayescal.core.checks.adequacy.describe`
    says where)."""


class NotConvergedWarning(UserWarning):
    """A chain stopped at ``max_steps`` without meeting the convergence rule:
    its intervals are provisional."""


class BudgetSpent(Exception):
    """A stage's work budget (:class:`bayescal.core.budget.Budget`) is used
    up: raised inside the stage's computation, caught by the stage, which
    ends with its best point so far."""


class OffChart(Exception):
    """A least-squares polish reached an axis at its chart's edge
    (:func:`bayescal.core.fit.modes.off_chart`): raised from its Jacobian,
    caught by the polish, which then has no optimum to report."""


class BudgetWarning(UserWarning):
    """A stage of a fit ended by its work budget, before its own rule
    (:meth:`bayescal.core.budget.Budget.note` says which, and what helps)."""
