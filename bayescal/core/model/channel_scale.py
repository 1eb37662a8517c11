"""A noise scale per SUT channel: each channel's share of a band's whitened
residual energy, and the misfit scale (:mod:`.misfit_scale`) applied to each
channel's shares.

The scale of :mod:`.misfit_scale` belongs to a band and multiplies the whole
band's noise covariance: every SUT channel of the band widens alike. Real
channels differ (one channel's incoherent noise can exceed the noise model
more than another's), so here each channel has its own scales.

**The split.** A band's Gaussian term is ``-q_b`` with ``q_b = x^T W x / 2``
for a real statistic ``x`` of precision ``W`` (errors in variables,
:mod:`.eiv`), or ``q_b = tr(A R B R^H)`` for the complex residual ``R``
(n_u x n_r) with row precision ``A`` and column precision ``B``
(:mod:`.likelihood`). Whitening with the symmetric square root of the
precision, ``z = W^(1/2) x`` (or ``A^(1/2) R B^(1/2)``), gives ``q_b =
|z|^2 / 2`` (or ``|z|^2``), and channel c's share ``q_bc`` is the energy of
c's entries of ``z`` (c's row of ``R``: its ``n_r`` reference columns, real
and imaginary parts). The shares sum to ``q_b``. Where the model holds the
entries of ``z`` are independent standard normals on the statistic's support,
so ``q_bc`` has mean ``k_bc``, the trace of the support's projector over c's
entries, halved, and is Gamma(k_bc, 1) exactly where that projector does not
mix the channels (a full-rank precision; a singular one gives a weighted sum
of chi-square terms, Gamma only approximately) (``n_r`` per time block for the complex
residual; the shares of ``k_b`` sum to it). Where the noise covariance has
no terms between channels the square root is block diagonal and ``q_bc``
is channel c's own whitened energy; where it has them, the symmetric root is
the whitening nearest the identity (it mixes the channels least and depends
on no ordering of them, unlike a Cholesky factor), and a scale ``s_c`` on
c's whitened entries multiplies the noise covariance by ``V^(1/2) D
V^(1/2)``, ``D`` the scales on c's entries: the channel's own covariance
times ``s_c`` up to terms of the order of the channels' correlation.

**The scales.** Each channel's energies ``q_bc`` (over the bands) enter
:func:`.misfit_scale.band_loglik` as a band's do in the shared form, with
``k_bc`` as degrees of freedom and the band weights: per channel and band
(:data:`.misfit_scale.OWN_SCALE_PROB` 1), pooled per channel across the
bands with each band its own with probability ``pi``, or floored
(:data:`.misfit_scale.FACTOR_FLOOR`). The channels' terms add: their scales
are independent a priori. Derivation and measurements:
docs/validation/misfit_scale.md, "A scale per channel".
"""
from __future__ import annotations

import numpy as np

from . import misfit_scale

def sym_sqrt(p, rtol=1e-13):
    """``(root, support)``: the symmetric (Hermitian) square root of each
    positive semi-definite matrix ``p`` (..., n, n) and the projector onto
    its support (eigenvalues above ``rtol`` times the largest)."""
    lam, u = np.linalg.eigh(p)
    keep = lam > rtol * lam[..., -1:]
    root = np.sqrt(np.where(keep, lam, 0.0))
    uh = np.conj(np.swapaxes(u, -1, -2))
    return (u * root[..., None, :]) @ uh, (u * keep[..., None, :]) @ uh


def real_channel_energy(x, w, n_u):
    """Per-channel shares of ``q_b = x^T W x / 2`` for a real statistic laid
    out as ``[Re vec R; Im vec R]`` with ``vec R`` row-major over (n_u, n_r)
    (:func:`bayescal.core.model.refnoise.as_real`).

    Parameters
    ----------
    x : (N, B, 2m) the statistic, ``m = n_u n_r``.
    w : (B, 2m, 2m) its precision (a pseudo-inverse where it is singular).
    n_u : the number of SUT channels.

    Returns
    -------
    ``(q, k)``: (N, B, n_u) the shares, summing over channels to ``x^T W
    x / 2``, and (B, n_u) their complex degrees of freedom, summing over
    channels to half the precision's rank.
    """
    root, support = sym_sqrt(w)
    z = (root @ x[..., None])[..., 0]                                 # (N, B, 2m)
    owner = _entry_channel(x.shape[-1], n_u)                          # (2m, n_u)
    q = 0.5 * (z ** 2) @ owner
    k = 0.5 * np.einsum("bii,ic->bc", support, owner)
    return q, k


def complex_channel_energy(r, a, b):
    """Per-channel shares of ``q_b = sum_g tr(A_b R_bg B_bg R_bg^H)``.

    Parameters
    ----------
    r : (N, G, B, n_u, n_r) the residual per time block.
    a : (B, n_u, n_u) its row (SUT) precision.
    b : (G, B, n_r, n_r) its column (reference) precision.

    Returns
    -------
    ``(q, k)``: (N, B, n_u) the shares and (B, n_u) their complex degrees of
    freedom (``G n_r`` each).
    """
    root, _ = sym_sqrt(a)
    m = np.einsum("ngbij,gbjk,ngblk->nbil", r, b, r.conj())            # sum_g R B R^H
    q = np.einsum("bci,nbij,bjc->nbc", root, m, root).real
    k = np.full(q.shape[1:], float(r.shape[1] * r.shape[4]))
    return q, k


def _entry_channel(n_entries, n_u):
    """(2m, n_u) 0/1: the SUT channel of each entry of a real statistic."""
    m = n_entries // 2
    n_r = m // n_u
    row = np.eye(n_u)[np.arange(m) // n_r]
    return np.concatenate([row, row])


def channel_energy(model, theta):
    """``(q, k)``: (N, B, n_u) each SUT channel's share of each band's
    whitened residual energy at ``theta`` (N, ndim) and (B, n_u) their
    degrees of freedom, for the base model or the errors-in-variables one
    (whose noise model holds the statistic's precision ``W``)."""
    theta = np.atleast_2d(theta)
    noise = model.noise
    n_u = model.spectra.n_u
    if getattr(noise, "W", None) is not None:
        x, _ = model.statistic(theta)
        return real_channel_energy(x, noise.W, n_u)
    return complex_channel_energy(model.residual_blocks(theta), noise.A, noise.B)


def channel_loglik(q, k, a, weight=None, pi=None, floor=None):
    """The log likelihood with a noise scale per channel: the sum over SUT
    channels of :func:`.misfit_scale.band_loglik` of the channel's shares.

    Parameters
    ----------
    q : (N, B, n_u) each channel's share of each band's energy.
    k : (B, n_u) their complex degrees of freedom.
    a, weight, pi, floor : as :func:`.misfit_scale.band_loglik` (``a``
        infinite: the Gaussian, the same as the shared form's).

    Returns
    -------
    (N,) the log likelihood.
    """
    q, k = np.asarray(q, float), np.asarray(k, float)
    return sum(misfit_scale.band_loglik(q[..., c], k[:, c], a, weight, pi, floor)
               for c in range(q.shape[-1]))


def log_likelihood(model, theta):
    """A model's log likelihood with a noise scale per SUT channel (the
    hook of :meth:`bayescal.core.model.likelihood.Model.log_likelihood`,
    taken where :data:`.misfit_scale.PER_CHANNEL` is on)."""
    q, k = channel_energy(model, theta)
    return channel_loglik(q, k, model.misfit_shape, getattr(model.noise, "weight", None))


def channel_scale(q, k, a, weight=None, pi=None, floor=None):
    """(B, n_u) the factor by which each channel's noise variance in each
    band is effectively scaled at energies ``q`` (B, n_u)
    (:func:`.misfit_scale.band_scale` per channel)."""
    q, k = np.asarray(q, float), np.asarray(k, float)
    return np.stack([misfit_scale.band_scale(q[:, c], k[:, c], a, weight, pi, floor)
                     for c in range(q.shape[-1])], axis=1)
