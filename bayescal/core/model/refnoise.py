"""The reference sensor's own self-noise (errors in variables): the statistic
and its exact covariance.

With ``Y_u = T s + n_u`` and ``Y_r = s + n_r`` (ground units, reference
channel frame, per bin), the band residual of :mod:`bayescal.core.model.likelihood`,
``R_b = S_ur,b(a) - T S_rr,b``, has the mean ``-T N_r,b`` (``N_r,b`` the
reference's self-noise summed over the band's bins and segments): the
regression dilution that biases gains low by about the reference's coherence
deficit, and leans the axes when the ground field is anisotropic. The
statistic used instead puts the noise back,

    R_b = S_ur,b(a) - T S_rr,b + T diag(d_b),

zero-mean at the truth when ``d_b = N_r,b``. Modes (``MODES``):

``quiet``
    ``d = 0``: the base model, for a reference much quieter than the SUT.
``estimate``
    ``d_b,k = c_k0 w_b,k + c_k1 h_b,k``: the reference's noise as a
    combination of two fixed spectral shapes (:func:`noise_shapes`): white
    in ground units, and white in the reference's counts (``1 / |H_r|^2``,
    rising below its corner as real self-noise does). ``c`` (two numbers
    per reference channel for the whole band) enters linearly and is
    profiled out in closed form per walker (:func:`profile_columns`), so the
    sampled likelihood is the profile likelihood and carries the noise's
    uncertainty into the intervals. It is identified because self-noise is
    smooth and the ambient field is not (the microseism peak), pooled over
    the band. The statistic is the plain residual plus a parameter term, so
    its covariance is the base model's.
``equal``
    ``d_b,k = n_u,b,i(k)``: the SUT's own noise in the channel ``i(k)`` along
    reference channel ``k``, read from its spectra, ``n_u = diag(S_uu(a) -
    S_ur(a) T^T)`` (two sensors of one class with the same self-noise in
    ground units). This term is data: its covariance has a pseudo-covariance
    part (below).

Covariance. Every term is linear in the band's cross-spectral matrix ``S``
(all channels, SUT first): ``R = sum_t A_t S B_t``. For a complex Wishart
``S`` with ``K`` degrees of freedom and per-bin covariance ``C``,

    E[dR_pq conj(dR_rs)] = K sum_tt' (A_t C A_t'^H)_pr (B_t'^H C B_t)_sq,
    E[dR_pq dR_rs]       = K sum_tt' (A_t C B_t')_ps (A_t' C B_t)_rq,

which give the covariance of ``x = [Re vec R; Im vec R]``. The second term
vanishes for the plain residual (``A C B = E[R]/K = 0``: the base model's
``Sigma (x) S_rr^T``) but not once the SUT's own noise enters (mode
``equal``): then ``Re R`` and ``Im R`` have different variances and some
combinations are identically zero. See docs/validation/errors_in_variables.md.
"""
from __future__ import annotations

import numpy as np

from .noise_range import NoiseRange

MODES = ("quiet", "estimate", "equal")

#: The mode for pairs of two or more channels on each side, and the default
#: of :func:`bayescal.calibrate` and ``bayescal fit`` there
#: (docs/validation/errors_in_variables.md): unbiased whatever the split of
#: noise, at about 1.5 times the CPU of ``quiet`` (see :func:`recommended_mode`).
RECOMMENDED = "estimate"


def recommended_mode(n_ref, n_sut):
    """The ``--ref-noise`` mode for a pair of ``n_ref`` reference and ``n_sut``
    SUT channels: :data:`RECOMMENDED` when both have two or more channels
    (their cross-spectra separate the reference's noise from the ground
    motion), ``quiet`` otherwise (a one-channel pair cannot)."""
    return RECOMMENDED if min(n_ref, n_sut) >= 2 else "quiet"

def band_sums_of_psd(spectra, period_s, psd_db):
    """(B,) a self-noise PSD given as dB re 1 (m/s^2)^2/Hz at ``period_s``
    (the ``bayescal noise`` / NLNM convention) as band sums in the units of
    ``spectra``'s band sums (ground velocity, summed over the band's bins and
    the segments), the ``d_b`` of mode ``fixed``. Interpolated linearly in
    dB against log period at every bin; periods outside the given ones take
    the nearest value (said by the caller). Entries that are not finite
    (a ``null`` estimate) are skipped."""
    period_s = np.asarray(period_s, float)
    psd_db = np.asarray([np.nan if v is None else v for v in psd_db], float)
    ok = np.isfinite(period_s) & np.isfinite(psd_db) & (period_s > 0)
    if ok.sum() < 2:
        raise ValueError("a self-noise PSD needs at least two finite values")
    order = np.argsort(np.log(period_s[ok]))
    logp, db = np.log(period_s[ok])[order], psd_db[ok][order]
    f = spectra.freqs
    acc = 10.0 ** (np.interp(np.log(1.0 / f), logp, db) / 10.0)         # (m/s^2)^2/Hz
    vel = acc / (2.0 * np.pi * f) ** 2                                    # (m/s)^2/Hz
    per_bin = vel / spectra.psd_scale * spectra.n_segments
    return np.bincount(spectra.band_of, weights=per_bin, minlength=spectra.n_bands)


def treatment_meta(model, theta):
    """How the reference's self-noise was treated, for result.json."""
    mode = getattr(model, "ref_noise", "quiet")
    out = {"mode": mode, "assumption": {
        "quiet": "the reference's self-noise is negligible next to the SUT's",
        "equal": "both sensors have the same self-noise in ground units",
        "estimate": "the reference's self-noise estimated from the data, as white in ground "
                    "units plus white in its counts",
        "fixed": "the reference's self-noise as given (a third sensor or the user's model)"
        }[mode]}
    if getattr(model, "on_bound", lambda t: False)(theta):
        out["bounded"] = ("the spectra cannot tell the reference's self-noise from the SUT's "
                          "here: it is kept within the incoherent power they show")
    if mode != "quiet":
        psd = model.reference_noise_psd(theta)                      # (m/s)^2/Hz per band
        w2 = (2 * np.pi * model.spectra.band_centres) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            db = 10 * np.log10(psd * w2[:, None])
        out["reference_self_noise"] = {
            "band_centre_hz": model.spectra.band_centres.tolist(),
            "psd_db": {cid: [None if not np.isfinite(v) else round(float(v), 2) for v in col]
                       for cid, col in zip(model.spectra.ref_ids, db.T)},
            "units": "dB re 1 (m/s^2)^2/Hz at the least-squares point (no interval yet)"}
    return out


#: Relative ridge on the profile system of ``rho``.
RIDGE = 1e-9


def selectors(n_u, n_r, t):
    """(A0, B0) of the plain residual ``S_ur - T S_rr = A0 S B0`` and the SUT
    projector ``U = [I 0]``; ``t`` (n_u, n_r)."""
    a0 = np.concatenate([np.eye(n_u), -t], axis=1)                   # (nu, n)
    b0 = np.concatenate([np.zeros((n_u, n_r)), np.eye(n_r)], axis=0)  # (n, nr)
    u = np.concatenate([np.eye(n_u), np.zeros((n_u, n_r))], axis=1)   # (nu, n)
    return a0, b0, u


def noise_terms(t, along, weights):
    """The (A, B) pairs of the noise terms for one band: for reference
    channel k, ``weights[k] * (T e_k) n_u,i(k) e_k^T``. ``t`` (n_u, n_r),
    ``along`` (n_r,) SUT channel index per reference channel."""
    n_u, n_r = t.shape
    a0, _, u = selectors(n_u, n_r, t)
    out = []
    for k in range(n_r):
        i = along[k]
        a = weights[k] * np.outer(t[:, k], u[i])                     # (nu, n)
        b = np.outer(a0[i], np.eye(n_r)[k])                          # (n, nr)
        out.append((a, b))
    return out


def real_covariance(terms, c, k):
    """Covariance (2m, 2m) of ``[Re vec R; Im vec R]`` (row-major vec, m =
    n_u n_r) for ``R = sum_t A_t S B_t``, ``S`` complex Wishart(K, C)."""
    gam = 0.0
    pse = 0.0
    for at, bt in terms:
        for au, bu in terms:
            g = np.einsum("pr,sq->pqrs", at @ c @ au.conj().T, bu.conj().T @ c @ bt)
            p = np.einsum("ps,rq->pqrs", at @ c @ bu, au @ c @ bt)
            gam = gam + g
            pse = pse + p
    m = terms[0][0].shape[0] * terms[0][1].shape[1]
    gam = k * np.reshape(gam, (m, m))
    pse = k * np.reshape(pse, (m, m))
    re = 0.5 * np.real(gam + pse)
    im = 0.5 * np.real(gam - pse)
    ri = 0.5 * np.imag(pse - gam)
    return np.block([[re, ri], [ri.T, im]])


def as_real(r):
    """(..., n_u, n_r) complex -> (..., 2 n_u n_r) real ``[Re vec; Im vec]``."""
    flat = r.reshape(r.shape[:-2] + (-1,))
    return np.concatenate([flat.real, flat.imag], axis=-1)


def noise_shapes(spectra):
    """(B, n_r, 2) band sums of two spectral shapes of the reference's
    self-noise, each scaled to the mean of the reference's band power: white
    in ground units, and white in the reference's counts (``1 / |H_r|^2``;
    ``f^-2`` when the channel is already in ground units). Mode
    ``estimate`` fits the reference's noise as a combination of the two."""
    nb, nu, nr = spectra.n_bands, spectra.n_u, spectra.n_r
    onehot = np.eye(nb)[spectra.band_of]                                  # (F, B)
    white = np.broadcast_to(onehot.sum(axis=0)[:, None], (nb, nr))
    pw = spectra.response_power
    inv = (1.0 / pw[nu:].T) if pw is not None else np.ones((spectra.freqs.size, nr))
    counts = onehot.T @ inv                                               # (B, nr)
    # a channel already in ground units (flat) would give two equal shapes
    flat = np.ptp(np.log(counts / white), axis=0) < 0.1
    counts[:, flat] = (onehot.T @ spectra.freqs[:, None] ** -2.0)[:, [0] * int(flat.sum())]
    srr = np.real(np.einsum("bkk->bk", spectra.band_sums()[:, nu:, nu:])).mean(axis=0)
    out = np.stack([white, counts], axis=2)
    return out / out.mean(axis=0, keepdims=True) * srr[None, :, None]


def band_matmul(w, x):
    """``w_b @ x_b`` for every leading index: ``w`` (B, n, n), ``x`` (W, B,
    n, k) -> (W, B, n, k), as B matrix products over all W k columns at once
    (a stack of W B small products costs several times more)."""
    nw, nb, n, k = x.shape
    xt = np.ascontiguousarray(x.transpose(1, 2, 0, 3)).reshape(nb, n, nw * k)
    return (w @ xt).reshape(nb, n, nw, k).transpose(2, 0, 1, 3)


def admissible_noise(spectra):
    """(lower, upper), each (B, n_r): the range of the reference's self-noise
    (band sums) the spectra admit. The upper end is each reference
    channel's band power not coherent with the SUT's channels (``S_rr,kk -
    S_ru S_uu^-1 S_ur``, band sums; a regression on the ``n_u`` SUT channels
    leaves ``K_b - n_u`` of the band's ``K_b`` complex degrees of freedom,
    bins times segments, so it is scaled by ``K_b / (K_b - n_u)`` to be
    unbiased) plus three standard errors of that estimate (relative ``1 /
    sqrt(K_b - n_u)``): whatever the split of the incoherent power between
    the two sensors, neither sensor's noise exceeds it. The lower end is
    zero less the same three standard errors: noise is never negative, and
    the margin lets a quiet reference's estimate scatter about its zero as
    the spectra's sampling error does."""
    s = spectra.band_sums()
    nu = spectra.n_u
    suu, sur = s[:, :nu, :nu], s[:, :nu, nu:]
    explained = np.einsum("bik,bil->bkl", sur.conj(), np.linalg.solve(suu, sur))
    inc = np.real(np.einsum("bkk->bk", s[:, nu:, nu:]) - np.einsum("bkk->bk", explained))
    k = (spectra.bins_per_band * spectra.n_segments).astype(float)
    left = np.maximum(k - nu, 1.0)
    power = np.maximum(inc, 0.0) * (k / left)[:, None]
    margin = power * (3.0 / np.sqrt(left))[:, None]
    return -margin, power + margin


def profile_columns(x0, u, shapes, w, bounds=None):
    """The reference's noise profiled out of the statistic ``x0 + G c``.

    Column ``(k, j)`` of the design ``G`` is ``u[..., k] * shapes[b, k, j]``
    (the noise term of reference channel ``k``, ``T e_k``, times shape
    ``j``'s band sum), so ``c`` maximising ``-sum_b (x0_b + G_b c)^T W_b
    (x0_b + G_b c)`` solves a ``2 n_r`` system built from one Gram matrix of
    ``[x0, u]`` per band (the dense design has ``2 n_r`` columns, each
    ``n_u`` of ``2 m`` rows non-zero); the quadratic form of the profiled
    statistic comes from the same Gram matrix.

    ``x0`` (W, B, 2m), ``u`` (W, B, 2m, n_r), ``shapes`` (B, n_r, 2), ``w``
    (B, 2m, 2m) symmetric. ``bounds`` = (lower, upper), each (B, n_r), or
    None: each channel's noise ``d_b,k`` is kept within ``[lower_b,k,
    upper_b,k]`` (:func:`admissible_noise`: never negative beyond the
    spectra's sampling error, never more than the incoherent power they
    show). Returns ``(c, G c, q)``: (W, n_r, 2), (W, B, 2m) and ``q_b =
    x_b^T W_b x_b`` of ``x = x0 + G c``, (W, B).
    """
    nw, nb, _, nr = u.shape
    gram, h, grad = _profile_system(x0, u, shapes, w)
    m_kl, gx = gram[..., 1:, 1:], gram[..., 0, 1:]
    c = -np.linalg.solve(h, grad[..., None])[..., 0].reshape(nw, nr, 2)
    if bounds is not None and not isinstance(bounds, NoiseRange):
        bounds = NoiseRange(shapes, *bounds)
    if bounds is not None:
        d = (shapes[None] * c[:, None]).sum(axis=-1)                   # (W, B, nr)
        out = np.any((d > bounds.upper[None]) | (d < bounds.lower[None]), axis=(1, 2))
        if out.any():
            c[out] = bounds.minimum(h[out], grad[out], c[out])
    per_band = (shapes[None] * c[:, None]).sum(axis=-1)                # (W, B, nr)
    q = (gram[..., 0, 0] + 2.0 * (gx * per_band).sum(axis=-1)
         + ((m_kl @ per_band[..., None])[..., 0] * per_band).sum(axis=-1))
    return c, (u * per_band[..., None, :]).sum(axis=-1), q


def _profile_system(x0, u, shapes, w):
    """The Gram matrix of ``[x0, u]`` per band and the profile's normal
    equations ``h c = -grad`` (``h`` with its relative ridge)."""
    nw, nb, _, nr = u.shape
    xu = np.concatenate([x0[..., None], u], axis=-1)                   # (W, B, 2m, 1+nr)
    gram = np.swapaxes(xu, -1, -2) @ band_matmul(w, xu)                # (W, B, 1+nr, 1+nr)
    m_kl, gx = gram[..., 1:, 1:], gram[..., 0, 1:]
    # h[(k, j), (l, i)] = sum_b s_bkj s_bli M_bkl, grad[(k, j)] = sum_b s_bkj gx_bk:
    # sums over bands as one matrix product per (k, l) pair, resp. per k
    pair = (shapes[:, :, None, :, None] * shapes[:, None, :, None, :]).reshape(nb, nr * nr, 4)
    h = np.ascontiguousarray(m_kl.reshape(nw, nb, nr * nr).transpose(2, 0, 1)) @ \
        pair.transpose(1, 0, 2)                                        # (nr nr, W, 4)
    h = h.reshape(nr, nr, nw, 2, 2).transpose(2, 0, 3, 1, 4).reshape(nw, 2 * nr, 2 * nr)
    grad = np.ascontiguousarray(gx.transpose(2, 0, 1)) @ shapes.transpose(1, 0, 2)  # (nr, W, 2)
    grad = grad.transpose(1, 0, 2).reshape(nw, 2 * nr)
    scale = np.trace(h, axis1=1, axis2=2)[:, None, None] / h.shape[-1]
    return gram, h + RIDGE * scale * np.eye(h.shape[-1]), grad
