"""A per-band noise scale, marginalised: intervals that widen where the
residual is larger than the noise model allows.

The Gaussian likelihood of band b is ``-q_b`` with ``q_b`` the whitened
residual energy (complex form: ``q_b = tr(A_b R_b B_b R_b^H)``; real form:
``chi2_b / 2``), which is Gamma(k_b, 1) where the model fits, ``k_b`` the
band's complex degrees of freedom (half its real ones). Multiply the band's
noise covariance by an unknown scale ``s_b`` with an inverse-gamma prior of
shape ``a`` and scale ``a`` (concentrated near 1: mode ``a / (a + 1)``,
relative spread about ``1 / sqrt(a)``) and integrate it out:

    int s^-k exp(-q / s) IG(s; a, a) ds  ∝  (1 + q / a)^-(a + k),

so each band contributes ``-(a + k_b) log(1 + q_b / a)`` (a Student-t-like
term). Its slope in ``q_b`` is ``(a + k_b) / (a + q_b)``: about 1 where the
band fits (``q_b ~ k_b``, the Gaussian back) and ``k_b / q_b``-like where the
misfit is large, i.e. the band's variance is scaled by about its own
``q_b / k_b`` (a per-band Birge ratio) and the intervals widen with it.
``a = inf`` is the Gaussian. Derivation, choice of ``a`` and measurements:
docs/validation/misfit_scale.md.
"""
from __future__ import annotations

import numpy as np

#: Shape (and scale) of the inverse-gamma prior on each band's noise scale
#: used by a fit (docs/validation/misfit_scale.md says why this value).
MISFIT_SHAPE = 2.0


def band_loglik(q, k, a, weight=None):
    """Sum over bands of the marginalised band term.

    Parameters
    ----------
    q : (W, B) whitened residual energy per band (the Gaussian term is ``-q``).
    k : (B,) complex degrees of freedom of each band's residual.
    a : prior shape; ``inf`` (or None) gives the Gaussian ``-sum q``.
    weight : (B,) or None, each band's term multiplied by it (the plug-in
        noise model's sampling error, :mod:`bayescal.core.model.plugin`).
    """
    q = np.asarray(q, float)
    w = 1.0 if weight is None else np.asarray(weight, float)
    if a is None or not np.isfinite(a):
        return -np.sum(w * q, axis=1)
    k = np.asarray(k, float)
    return -np.sum(w * (a + k) * np.log1p(q / a), axis=1)


def band_scale(q, k, a):
    """(B,) the factor by which each band's noise variance is effectively
    scaled at residual energy ``q`` (B,): ``(a + q) / (a + k)``, the inverse
    of the band's weight relative to the Gaussian; 1 for ``a = inf``."""
    q = np.asarray(q, float)
    if a is None or not np.isfinite(a):
        return np.ones_like(q)
    return (a + q) / (a + np.asarray(k, float))


def describe(a, q=None, k=None):
    """The ``result.json`` entry ``meta.misfit_scale``."""
    gaussian = a is None or not np.isfinite(a)
    out = {"shape_a": None if gaussian else float(a),
           "model": "Gaussian noise model (no misfit scale)" if gaussian else
                    f"per-band noise scale s_b ~ InverseGamma({a:g}, {a:g}), marginalised: each "
                    "band's term is -(a + k_b) log(1 + q_b / a); bands whose residual exceeds "
                    "the noise model are down-weighted and intervals widen (docs/validation/misfit_scale.md)"}
    if q is not None:
        out["band_variance_factor"] = [round(float(v), 4) for v in band_scale(q, k, a)]
    return out
