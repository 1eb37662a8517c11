"""The third step of a pair fit: when its model check fails, what the model
leaves out and whether modelling it moves the estimates
(:func:`bayescal.criticism.verdict.criticise`); when it passes, whether a
channel fits reversed or exchanged (:func:`bayescal.criticism.verdict.check_orientation`)."""
from __future__ import annotations

from ..core.checks.adequacy import from_diagnostics
from ..criticism.verdict import DEFAULT_BUDGET_S, Criticism


def criticise(state, *, budget_s=DEFAULT_BUDGET_S, seed=0, enabled=True, **sample_kw):
    """The :class:`~bayescal.criticism.verdict.Criticism` of ``state`` (a
    :class:`~bayescal.core.posterior.state.FitState`): its ``summary`` is
    empty when nothing was criticised (``enabled`` False, a fit without a
    model, or no model check), and ``improved`` the improved model's
    state, or None. An error in the search is said in the summary: the
    fit's results stand without it."""
    from ..criticism.verdict import check_orientation, criticise as run, failed

    if not enabled or state.model is None or state.theta_ls is None:
        return Criticism({})
    ok = from_diagnostics(state.diagnostics).get("ok")
    if ok is None:
        return Criticism({})
    if ok:      # the orientation is fitted freely: a reversed channel fits, but say so
        return Criticism(check_orientation(state) or {})
    try:
        return run(state, budget_s=budget_s, seed=seed, **sample_kw)
    except Exception as exc:   # noqa: BLE001 - the fit's results stand without it
        return Criticism(failed(exc))
