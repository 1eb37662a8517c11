"""Interpolation weights and band membership folded into per-time-block
cross-spectra, band by band.

``fold(interp, band_of, n_bands, c)`` is ``einsum("fq,fb,gfij->giqbj",
interp, onehot(band_of), c)`` for ``c`` (G, F, n, m): each bin belongs to one
band, so every band is one matrix product over its own bins (F Q G n m
products instead of the three-operand einsum's F Q B G n m, which cost a
diagnose search 1.3 s per per-block model). Sums run in another order:
equal to rounding (``tests/test_jacobian.py``).
"""
from __future__ import annotations

import numpy as np


def fold(interp, band_of, n_bands, c):
    """(G, n, Q, B*m) from ``interp`` (F, Q), ``band_of`` (F,), ``c`` (G, F, n, m)."""
    g, _, n, m = c.shape
    q = interp.shape[1]
    out = np.zeros((g, n, q, n_bands, m), dtype=np.result_type(interp, c))
    for b in range(n_bands):
        sel = np.flatnonzero(band_of == b)
        if not sel.size:
            continue
        rows = np.ascontiguousarray(c[:, sel].transpose(1, 0, 2, 3)).reshape(sel.size, -1)
        part = (interp[sel].T @ rows).reshape(q, g, n, m)        # (Q, G, n, m)
        out[:, :, :, b, :] = part.transpose(1, 2, 0, 3)
    return out.reshape(g, n, q, n_bands * m)
