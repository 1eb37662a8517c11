"""How well a pair separates the reference's self-noise from the SUT's gains
(``--ref-noise estimate``).

In mode ``estimate`` the reference's noise along channel ``k`` adds
``T e_k d_k`` to the statistic: it rescales column ``k`` of the transfer
``T``, as a relative gain does. The two are told apart only by spectral
shape: the noise is a fixed combination of two smooth shapes over the whole
band, while the ground motion's spectrum has peaks (microseisms). Over a
narrow band, or where the self-noise has the ground motion's own shape
(``S_ur / S_rr = T / (1 + x)`` for a constant noise-to-signal ``x``), they
are not: the profiled noise takes up part of each gain, and the gains'
intervals widen, honestly, by a large factor.

This module measures that widening: the least-squares standard deviation of
each SUT gain under the fitted errors-in-variables model against its
standard deviation under the quiet-reference model (the reference's noise
taken as zero) at the same point (its Fisher information there, one
vectorised Jacobian: a few per cent of a fit's time), both with the
errors-in-variables model's band weights (:mod:`bayescal.core.model.plugin`), so the ratio
measures the separation and not the two plug-ins' different dimensions (on
a 15-minute record the quiet model's own weights, ``p = n_u`` against
``n_u + n_r``, would add 10-20 %). A ratio above :data:`WIDE_RATIO` is
reported in ``result.json`` (``meta.reference_noise.separation``) and on the
console with what to do.
"""
from __future__ import annotations

import numpy as np

#: Gain standard deviations wider than this multiple of the quiet model's are reported.
WIDE_RATIO = 1.5


def gain_separation(model, theta, cov):
    """``{"gain_sd_ratio": {channel: ratio}, "note": ...}`` for an
    errors-in-variables ``model`` (mode ``estimate``) at its least-squares
    point ``theta`` with covariance ``cov``; ``note`` only when a ratio
    exceeds :data:`WIDE_RATIO`. An empty dict when no gain is fitted or the
    quiet model's fit fails."""
    from ..model.jacobian import forward_jacobian
    from ..model.likelihood import Model

    idx = [j for j, n in enumerate(model.names) if n.endswith(":log_gain")]
    if not idx:
        return {}
    quiet = Model(model.spectra, model.ref_vectors, model.blocks, model.priors)
    quiet.inflation_floor = model.inflation_floor                       # like with like
    try:    # the quiet model's Fisher information at theta (its noise estimated there)
        quiet.estimate_noise(theta)
        quiet.noise.weight = getattr(model.noise, "weight", None)     # like with like
        jac = forward_jacobian(quiet, matmul=True)(np.asarray(theta, float),
                                                   quiet.noise.cholesky())
        cov_q = np.linalg.inv(2.0 * jac.T @ jac)
    except Exception:       # noqa: BLE001 - no comparison is better than a wrong one
        return {}
    ratio = {model.names[j].rsplit(":", 1)[0]: float(np.sqrt(cov[j, j] / cov_q[j, j]))
             for j in idx}
    out = {"gain_sd_ratio": ratio,
           "basis": "least-squares sd of each SUT gain with the reference's noise estimated, "
                    "over its sd with the reference taken as noise-free, at the same point"}
    worst = max(ratio.values())
    if worst > WIDE_RATIO:
        lo, hi = model.spectra.band_edges[0], model.spectra.band_edges[-1]
        out["note"] = (f"in this band ({lo:.3g}-{hi:.3g} Hz) the reference's self-noise is "
                       f"poorly separated from the SUT's gains (their intervals up to "
                       f"{worst:.1f} times wider than with the reference taken as noise-free): "
                       "a wider band, or a third co-located sensor (bayescal noise), "
                       "separates them; if the reference is known to be much quieter than "
                       "the SUT, --ref-noise quiet")
    return out
