"""The third step of a pair fit: when its model check fails, what the model
leaves out and whether modelling it moves the estimates
(:func:`bayescal.criticism.verdict.criticise`); when it passes, whether a
channel fits reversed or exchanged (:func:`bayescal.criticism.verdict.check_orientation`)."""
from __future__ import annotations

from ..core.checks import from_diagnostics
from ..criticism.verdict import DEFAULT_BUDGET_S, Criticism
from .preparation import USER_BAND


def criticise(state, *, budget_s=DEFAULT_BUDGET_S, seed=0, enabled=True, **sample_kw):
    """The :class:`~bayescal.criticism.verdict.Criticism` of ``state`` (a
    :class:`~bayescal.core.posterior.state.FitState`): its ``summary`` is
    empty when nothing was criticised (``enabled`` False, a fit without a
    model, or no model check), and ``improved`` the improved model's
    state, or None. An error in the search is said in the summary: the
    fit's results stand without it.

    Parameters
    ----------
    state : FitState
        From :func:`bayescal.pair.fitting.fit`.
    budget_s : float
        The criticism's work budget, stated in seconds: each stands for
        :data:`bayescal.criticism.verdict.WORK_PER_SECOND` model
        evaluations (about a second's work on a two-core computer), so the
        same seed names the same effects on any machine (checked between
        candidates; when it runs out the verdict is "unexplained" and says
        which candidates were tried). Ten times as many seconds of wall
        clock stop it as a safety net, and the criticism then says so.
    seed : int
        Random seed of the improved model's sampler.
    enabled : bool
        When the model check fails, criticise the fit (True, the default):
        find what the model leaves out, model it from the fit's own
        spectra and least-squares point, and give a verdict
        (``result.criticism``, result.json's ``criticism``; the improved
        model's result is ``result.improved``); see
        :mod:`bayescal.criticism.verdict`. False skips it (as ``bayescal
        fit --no-diagnose``).
    **sample_kw
        To the improved model's sampler.
    """
    from ..criticism.verdict import check_orientation, criticise as run, failed

    if not enabled or state.model is None or state.theta_ls is None:
        return Criticism({})
    ok = from_diagnostics(state.diagnostics).get("ok")
    if ok is None:
        return Criticism({})
    if ok:      # the orientation is fitted freely: a reversed channel fits, but say so
        return Criticism(check_orientation(state) or {})
    try:
        return run(state, budget_s=budget_s, seed=seed,
                   band_given=state.meta.band_choice == USER_BAND, **sample_kw)
    except Exception as exc:   # noqa: BLE001 - the fit's results stand without it
        return Criticism(failed(exc))
