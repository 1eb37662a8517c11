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
    """``A0 prod(x - z) / prod(x - p)`` at the complex points ``x`` (any
    shape; the result has ``x``'s shape).

    Parameters
    ----------
    x : complex array, e.g. ``2j * np.pi * freqs``.
    zeros, poles : sequences of complex roots, in ``x``'s units (none: a
        product of 1).
    a0 : the normalisation factor.
    """
    x = np.asarray(x, dtype=complex)
    zeros = np.asarray(zeros, dtype=complex).ravel()
    poles = np.asarray(poles, dtype=complex).ravel()
    num = np.prod(x[..., None] - zeros, axis=-1) if zeros.size else 1.0
    den = np.prod(x[..., None] - poles, axis=-1) if poles.size else 1.0
    return a0 * num / den * np.ones_like(x)


def normalization_factor(zeros, poles, norm_freq):
    """``A0 = 1 / |prod(s_n - z) / prod(s_n - p)|``, ``s_n = 2 pi i f_n``: the
    factor that makes a stage with poles and zeros in rad/s of gain 1 at
    ``norm_freq`` (Hz)."""
    return float(1.0 / abs(transfer(2j * np.pi * norm_freq, zeros, poles)))
