"""Does the model fit the recordings? A posterior-predictive check on the
per-band, per-SUT-channel standardised misfit every fit already computes
(:meth:`bayescal.core.model.likelihood.Model.standardized_band_residuals`).

Where the model fits, each band's whitened residual row holds ``n_r``
independent unit-variance complex Gaussian energies, so ``n_r * misfit`` is
Gamma(``n_r``, 1): its upper tail is the p-value of one cell. A fit passes
when no cell lies below ``ALPHA / cells`` (Bonferroni: a family-wise false
alarm rate of at most ``ALPHA`` per fit). The same test locates a mismatch in
:func:`bayescal.criticism.locate.locate`; ``bayescal diagnose`` then names and
models its cause.
"""
from __future__ import annotations

import numpy as np

#: Family-wise false-alarm level of the mismatch test (Bonferroni over cells).
ALPHA = 0.01


def band_p_values(misfit, n_r):
    """Upper-tail p-value of each standardised misfit cell: ``P(Gamma(n_r, 1)
    >= n_r * misfit)``."""
    from scipy.special import gammaincc   # on use: the criticism's constants load without it

    return gammaincc(n_r, n_r * np.asarray(misfit, float))


def mismatch_flags(p, alpha=ALPHA):
    """Cells whose p-value fails the Bonferroni-corrected level ``alpha``."""
    p = np.asarray(p, float)
    return p < alpha / max(p.size, 1)


def adequacy(misfit, band_edges, channel_ids, n_r, alpha=ALPHA):
    """The verdict stored in ``result.json["adequacy"]``.

    Parameters
    ----------
    misfit : (B, n_u) standardised misfit per band and SUT channel.
    band_edges : (B + 1,) band edges, Hz.
    channel_ids : SUT channel ids (columns of ``misfit``).
    n_r : number of reference channels.

    Returns ``{"ok", "alpha", "cells", "worst": {"band_hz", "channel",
    "misfit", "p"}, "failing": [...]}``; ``failing`` lists every cell that
    fails, worst first.
    """
    misfit = np.atleast_2d(np.asarray(misfit, float))
    p = band_p_values(misfit, n_r)
    flags = mismatch_flags(p, alpha)
    edges = np.asarray(band_edges, float)
    channel_ids = list(channel_ids)
    if len(channel_ids) != misfit.shape[1]:          # spectra without channel ids
        channel_ids = [str(i) for i in range(misfit.shape[1])]

    def cell(b, i):
        return {"band_hz": [float(edges[b]), float(edges[b + 1])], "channel": str(channel_ids[i]),
                "misfit": float(misfit[b, i]), "p": float(p[b, i])}

    order = np.argsort(p, axis=None)
    b, i = np.unravel_index(order[0], p.shape)
    failing = [cell(*np.unravel_index(k, p.shape)) for k in order if flags.flat[k]]
    return {"ok": not bool(flags.any()), "alpha": alpha, "cells": int(p.size),
            "test": f"standardised misfit per band and channel against Gamma({n_r}, 1/{n_r}); "
                    f"Bonferroni over {p.size} cells, family-wise level {alpha:g}",
            "worst": cell(b, i), "failing": failing}


def from_diagnostics(diagnostics, alpha=ALPHA):
    """:func:`adequacy` from a fit's diagnostics dict (``band_misfit``,
    ``band_edges``, ``sut_ids``, ``ref_ids``), or a verdict of ``ok: None``
    when the fit kept no per-band misfit (the one-angle rotation fit)."""
    d = diagnostics or {}
    if "band_misfit" not in d:
        return {"ok": None, "note": "no per-band misfit for this kind of fit: not checked"}
    return adequacy(d["band_misfit"], d["band_edges"], [str(s) for s in d["sut_ids"]],
                    len(d["ref_ids"]), alpha)


def describe(verdict, next_step=None):
    """One line for a user: the verdict, where the model misses most, and
    what to do next. The test itself is described in the documentation
    (docs/science.md, "The model check")."""
    if verdict.get("ok") is None:
        return f"model check: {verdict.get('note', 'not computed')}"
    w = verdict["worst"]
    where = (f"{w['misfit']:.3g} in {w['band_hz'][0]:.4g}-{w['band_hz'][1]:.4g} Hz on "
             f"{w['channel']}")
    if verdict["ok"]:
        return (f"model check: passed: the recordings agree with the model within their noise "
                f"(largest standardised misfit {where}; about 1 is a fit within the noise)")
    first = (f"MODEL DOES NOT FIT THE DATA: standardised misfit {where}, where about 1 is a fit "
             "within the noise (more than noise explains; docs/science.md, \"The model check\"). ")
    if next_step:       # the criticism ran: its verdict says what the misfit means
        return first + next_step
    return (first + "The intervals are widened where the model misses, but an effect the model "
            "leaves out can still shift the estimates: run `bayescal diagnose` with the same "
            "arguments to find and name the cause.")
