"""A poles-and-zeros transfer function and its normalisation:

    H(x) = A0 prod_k (x - z_k) / prod_k (x - p_k),

evaluated at ``x = s = 2 pi i f`` for an analog stage with poles and zeros in
rad/s (StationXML's ``LAPLACE (RADIANS/SECOND)``), ``x = i f`` for one in Hz,
``x = exp(i w dt)`` for a digital one. ``A0`` normalises ``|H|`` to 1 at the
normalisation frequency (:func:`normalization_factor`), as StationXML's
``NormalizationFactor``. Every poles-and-zeros product of bayescal is
evaluated here.
"""
from __future__ import annotations

import numpy as np


def transfer(x, zeros, poles, a0=1.0):
    """``A0 prod(x - z) / prod(x - p)`` at the complex points ``x``.

    Parameters
    ----------
    x : complex array (any shape), e.g. ``2j * np.pi * freqs``.
    zeros, poles : complex roots in ``x``'s units: a sequence (none: a product
        of 1), or sets of roots (..., n), one set per leading index (e.g. one
        per posterior draw), the same leading shape for both.
    a0 : the normalisation factor.

    Returns
    -------
    Complex array of ``x``'s shape, preceded by the roots' leading shape.
    """
    x = np.asarray(x, dtype=complex)
    num, den = (_product(x, roots) for roots in (zeros, poles))
    return a0 * num / den * np.ones_like(x)


def _product(x, roots):
    """``prod_k (x - r_k)`` over the last axis of ``roots`` (1.0 for none)."""
    roots = np.asarray(roots, dtype=complex)
    if roots.ndim < 2:
        roots = roots.ravel()
    if not roots.size:
        return 1.0
    shaped = roots.reshape(roots.shape[:-1] + (1,) * x.ndim + roots.shape[-1:])
    return np.prod(x[..., None] - shaped, axis=-1)


def normalization_factor(zeros, poles, norm_freq):
    """``A0 = 1 / |prod(s_n - z) / prod(s_n - p)|``, ``s_n = 2 pi i f_n``: the
    factor that makes a stage with poles and zeros in rad/s of gain 1 at
    ``norm_freq`` (Hz)."""
    return float(1.0 / abs(transfer(2j * np.pi * norm_freq, zeros, poles)))
