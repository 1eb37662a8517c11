"""The SUT's response as a fit sees it, relative to its metadata
(:func:`relative_response`): what the recordings measure of each SUT
channel's response, the channel blocks' response parameters and the
response effects of the model (a corner, missing poles, a delay) applied
at any frequency.

A pair of recordings measures the SUT's response relative to the
reference's metadata only: multiplied by the SUT's metadata response over
the reference's, the curve is what ObsPy's ``rel_calib_stack`` estimates
(``H_sut / H_ref``; see docs/diagnose.md, "The response as the data see
it").
"""
from __future__ import annotations

import numpy as np

from ..core.model import is_clock
from ..core.response import to_physical


def _block_factor(block, r, freqs):
    """(W, F) ``H_nom / H`` of one channel block at ``freqs`` for its
    response columns ``r`` (W, n): the families' functions the likelihood's
    :meth:`~bayescal.core.model.likelihood.Model.unpack` evaluates at its
    nodes."""
    w = r.shape[0]
    if block.free == "gain":
        return np.broadcast_to(1.0 / block.family.gain_only_ratio(np.exp(r[:, 0])),
                               (w, freqs.size))
    if block.free == "all":
        fam = block.family
        period, damping = to_physical(r[:, 0], r[:, 1], fam.period_s, fam.damping)
        return fam.inverse_ratio_at(freqs)(period, damping, np.exp(r[:, 2]))
    return np.ones((w, freqs.size), dtype=complex)


def model_response(model, theta, freqs, timing=False):
    """``H / H_meta`` (W, n_u, F) of ``model``'s SUT channels at the
    parameters ``theta`` (W, ndim) and frequencies ``freqs`` (Hz): the
    reciprocal of the likelihood's deconvolution factor (at the model's
    nodes, :meth:`~bayescal.core.model.likelihood.Model.unpack`'s ratio),
    each channel block's response times every effect's factor, with the
    clock effects (:func:`bayescal.core.model.effect.is_clock`) left out,
    or as the delay of their offset (a drift's at mid-record) where
    ``timing``. The one evaluation of the fitted response: result.json's
    ``response_curve`` (:mod:`bayescal.pair.response_curve`) is this at the
    model's nodes."""
    f = np.atleast_1d(np.asarray(freqs, float))
    theta = np.atleast_2d(theta)
    inverse = np.stack([_block_factor(b, theta[:, sr], f)
                        for b, (_, sr) in zip(model.blocks, model.slices)], axis=1)
    inverse = np.array(inverse, dtype=complex)
    for e, sl in zip(getattr(model, "effects", ()), getattr(model, "effect_slices", ())):
        if is_clock(e):
            if timing:
                tau = theta[:, sl][:, :1, None]
                inverse[:, e.rows] *= np.exp(2j * np.pi * f[None, None, :] * tau)
            continue
        if not getattr(e, "blocked", False):
            inverse[:, e.rows] *= e.factor(f, theta[:, sl])
    return 1.0 / inverse


def relative_response(state, freqs, *, draws=None, timing=True):
    """Each SUT channel's response under the model of ``state``, relative
    to its metadata response: ``H(f) / H_meta(f)`` per posterior draw
    (:func:`model_response`).

    Parameters
    ----------
    state : FitState
        A fit's or an improved model's (``result.state``, or
        ``result.improved`` of :func:`bayescal.calibrate`): its ``model`` and
        ``full_samples`` (model coordinates).
    freqs : array_like
        Frequencies, Hz.
    draws : int or None
        At most this many posterior draws, evenly spaced (None: all).
    timing : bool
        Include a timing offset (or a clock drift's offset at mid-record)
        as the delay it puts on the ratio the recordings show (True, what
        ObsPy's ``rel_calib_stack`` measures), or leave it out (False: a
        clock offset is a time correction of the data, not response).

    Returns
    -------
    (S, n_u, F) complex
        ``H / H_meta``; the gain relative to the metadata gain included.
        Times the SUT's metadata response over the reference's, it is the
        SUT's response over the reference's metadata (counts over counts).
    """
    theta = np.atleast_2d(state.full_samples if state.full_samples is not None
                          else state.theta_ls)
    if draws is not None and theta.shape[0] > draws:
        theta = theta[np.linspace(0, theta.shape[0] - 1, draws).astype(int)]
    return model_response(state.model, theta, freqs, timing=timing)
