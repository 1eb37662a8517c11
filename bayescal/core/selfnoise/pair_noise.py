"""Self-noise of both sensors of a pair fit, from the fitted transfer matrix.

Model (ground units, per bin, reference channel frame; :mod:`bayescal.core.model.refnoise`):
``Y_r = s + n_r`` and ``Y_u = T s + n_u`` with ``T`` (n_u, n_r) the fitted
transfer (SUT axes times the reference's pseudo-inverse, the SUT spectra
deconvolved by the fitted response), ``s`` the ground motion seen along the
reference's axes, and the self-noises independent of ``s`` and of each
other with diagonal spectra ``N_r``, ``N_u``. The expected band matrices are

    S_rr = S_ss + N_r,    S_ur = T S_ss,    S_uu = T S_ss T^H + N_u,

so, for ``T`` of full column rank (``n_u >= n_r``) with left inverse
``T^+ = (T^H T)^-1 T^H`` (``T^+ T = I``, so the square case is ``T^-1``),

    N_r = diag(S_rr - T^+ S_ur),      N_u = diag(S_uu - S_ur T^H).

Both are *linear* in the band matrices for a given ``T``, so at the true
``T`` each is exactly unbiased (``E[S_hat] = S`` for a Welch sum; real parts
taken, the imaginary parts are zero in expectation). Other forms are not:
``diag(S_uu - T S_rr T^H)`` carries ``-T N_r T^H`` and ``T^+ S_uu T^+H``
carries ``N_u``. ``N_u`` needs no inverse, so it also holds for ``n_u <
n_r`` (a SUT with fewer channels than the reference); ``N_r`` then is not
identifiable (``S_ss`` cannot be recovered from ``S_ur``).

A bias enters only through ``T``: a ``T`` fitted by regressing the SUT on a
noisy reference with free gains (``--ref-noise quiet``) is diluted by about
``N_r / S_rr``, which moves ``N_r`` low and ``N_u`` high by about ``N_r``; with
gains at nominal, or ``--ref-noise estimate|equal``, ``T`` is unbiased.
One channel per sensor identifies nothing: the gain and the two noises
trade off (Sleeman et al. 2006 need a third sensor).

Interval: normal on the power scale, with the complex-Wishart variance of
each (linear) estimate at the band's effective degrees of freedom
(:func:`bayescal.core.spectra.dof.band_dof`), the spectra's variation across each
band kept (:func:`sampling_variance`), plus the scatter of the estimate
over posterior draws of ``T``: the band holds the sampling scatter of the
spectra and the uncertainty of the fit. (A flat-band Wishart bootstrap, as
:func:`.sleeman.wishart_interval`, covered 0.83 on the simulations of
tests/test_pair_noise.py: the spectra vary across a band.)
"""
from __future__ import annotations

import numpy as np

from ..spectra.dof import band_dof
from .sleeman import acceleration_band_matrices, db

NOT_IDENTIFIABLE = ("not identifiable from one channel per sensor; use bayescal noise with a "
                    "third sensor")
NOT_IDENTIFIABLE_REF = ("not identifiable: the sensor under test has fewer channels than the "
                        "reference, so the ground motion along every reference axis cannot be "
                        "recovered; use bayescal noise with a third sensor")
#: Median margin (dB) over the band above which the reference is called the noisier sensor.
SWAP_MARGIN_DB = 3.0
#: Error of the metadata gains the sensor-order check with free gains allows for (+-3 %).
METADATA_GAIN_SPREAD = 0.03


def noise_from_t(S, t):
    """(..., n_u) SUT and (..., n_r) reference self-noise (real) from band
    matrices ``S`` (..., n, n) (SUT channels first, deconvolved by the fitted
    response) and the transfer ``t`` (..., n_u, n_r); the reference's is NaN
    when ``n_u < n_r``."""
    nu, nr = t.shape[-2:]
    suu, sur, srr = S[..., :nu, :nu], S[..., :nu, nu:], S[..., nu:, nu:]
    th = np.conj(np.swapaxes(t, -1, -2))
    n_u = np.real(np.einsum("...ii->...i", suu) - np.einsum("...ik,...ik->...i", sur, t.conj()))
    if nu < nr:
        return n_u, np.full(S.shape[:-2] + (nr,), np.nan)
    tp = np.linalg.solve(th @ t, th)                                   # (..., nr, nu)
    n_r = np.real(np.einsum("...kk->...k", srr) - np.einsum("...ki,...ik->...k", tp, sur))
    return n_u, n_r


def transfer(model, theta):
    """(R, B, n_u, n_r) transfer per band and (R, B, n_u) response
    correction at each band's centre, from model-coordinate draws ``theta``
    (R, ndim) of a :class:`bayescal.core.model.likelihood.Model`."""
    vecs, ratio = model.unpack(np.atleast_2d(theta))
    t = vecs @ model.ref_pinv                                          # (R, nu, nr)
    sp = model.spectra
    # band means of the interpolation weights first (linear, so the same
    # numbers as averaging the per-bin factors, at O(nodes) per draw)
    onehot = np.eye(sp.n_bands)[sp.band_of]                            # (F, B)
    wb = np.ascontiguousarray(model.node_weights.T @ (onehot / onehot.sum(axis=0)))   # (Q, B)
    rho_b = np.swapaxes(np.ascontiguousarray(ratio) @ wb, 1, 2)        # (R, B, nu)
    return np.broadcast_to(t[:, None], (t.shape[0], sp.n_bands) + t.shape[1:]), rho_b


def corrected(C, rho_b):
    """Band matrices (R, B, n, n) with the SUT rows/columns scaled by the
    response correction ``rho_b`` (R, B, n_u)."""
    nr = C.shape[-1] - rho_b.shape[-1]
    d = np.concatenate([rho_b, np.ones(rho_b.shape[:-1] + (nr,))], axis=-1)
    return d[..., :, None] * C * d[..., None, :].conj()


def _forms(t):
    """(n, n) vectors ``a_j``, ``b_j`` (rows) with estimate ``j`` =
    ``Re(a_j^H S b_j)``: SUT channel ``i`` is ``e_i^T S (e_i - [0; conj T_i])``,
    reference channel ``k`` is ``(e_k - [T^+_k; 0])^T S e_k``."""
    nu, nr = t.shape
    n = nu + nr
    a, b = np.zeros((n, n), complex), np.zeros((n, n), complex)
    for i in range(nu):
        a[i, i] = 1.0
        b[i, i] = 1.0
        b[i, nu:] = -np.conj(t[i])
    if nu >= nr:
        tp = np.linalg.solve(t.conj().T @ t, t.conj().T)
        for k in range(nr):
            a[nu + k, nu + k] = 1.0
            a[nu + k, :nu] = -np.conj(tp[k])
            b[nu + k, nu + k] = 1.0
    return a, b


def sampling_variance(model, t, rho_b, dof):
    """(B, n) variance of every channel's estimate from the sampling scatter
    of the spectra, at transfer ``t`` (n_u, n_r): for ``x = Re(a^H S b)`` of
    a band-mean matrix with ``nu_b`` effective degrees of freedom,

        var x = [ mean_f (a^H C_f a)(b^H C_f b) + Re (a^H C b)^2 ] / (2 nu_b),

    the complex-Wishart moments (:mod:`bayescal.core.model.refnoise`) with the band mean of the
    product over the band's bins instead of the product of band means (the
    two differ where the spectra vary across a band, e.g. at the microseism
    peak, and a flat-band Wishart then under-states the scatter)."""
    sp = model.spectra
    nu = sp.n_u
    a, b = _forms(t)
    d = np.concatenate([rho_b[sp.band_of], np.ones((sp.freqs.size, sp.n_r))], axis=1)  # (F, n)
    cf = d[:, :, None] * sp.total * d[:, None, :].conj()               # (F, n, n)
    qa = np.real(np.sum(a.conj().T[None] * (cf @ a.T), axis=1))        # (F, n): a_j^H C_f a_j
    qb = np.real(np.sum(b.conj().T[None] * (cf @ b.T), axis=1))
    onehot = np.eye(sp.n_bands)[sp.band_of]                            # (F, B)
    nb = sp.bins_per_band
    prod = onehot.T @ (qa * qb) / nb[:, None]                          # (B, n)
    cbar = onehot.T @ cf.reshape(cf.shape[0], -1) / nb[:, None]
    cbar = cbar.reshape(-1, *cf.shape[1:])
    mean = np.einsum("jp,bpq,jq->bj", a.conj(), cbar, b)
    var = (prod + np.real(mean ** 2)) / (2 * dof[:, None])
    # from velocity band means to acceleration: the scale of acceleration_band_matrices
    w2 = (2 * np.pi * sp.freqs) ** 2
    scale = sp.psd_scale / sp.n_segments / (np.bincount(sp.band_of, 1.0 / w2) / nb)
    var = var * scale[:, None] ** 2
    if nu < sp.n_r:
        var[:, nu:] = np.nan
    return var


def pair_self_noise(model, theta_point, theta_draws=None, level=0.9, n_draws=300, seed=0):
    """Self-noise of every channel of both sensors, acceleration PSD in
    (m/s^2)^2/Hz per band, with a ``level`` interval.

    ``model``: the fitted likelihood model (its ``spectra``, ``unpack``);
    ``theta_point`` (ndim,) the point estimate (posterior median);
    ``theta_draws`` (N, ndim) posterior samples (None: ``T`` held at the
    point). The interval is normal on the power scale (the estimate is a
    sum of many independent cross terms), its variance the spectra's
    sampling variance (:func:`sampling_variance`) plus the variance of the
    estimate over ``n_draws`` posterior draws of ``T``; a lower bound below
    zero is set to 0 (an upper bound only). Returns a dict: ``freq_hz``
    (B,), ``ids`` (SUT then reference), ``psd``, ``lo``, ``hi``, ``sd``
    (n, B), ``recorded`` (n, B) each channel's total PSD, ``identified``
    (n,) bool.
    """
    from statistics import NormalDist

    sp = model.spectra
    nu, nr = sp.n_u, sp.n_r
    C, fc = acceleration_band_matrices(sp)                             # (B, n, n)
    C = 0.5 * (C + np.conj(np.swapaxes(C, -1, -2)))
    t0, r0 = transfer(model, theta_point)
    c0 = corrected(C[None], r0)[0]
    pu, pr = noise_from_t(c0, t0[0])
    point = np.concatenate([pu, pr], axis=-1)                          # (B, n)
    dof = band_dof(sp)
    var = sampling_variance(model, t0[0, 0], r0[0], dof)
    if theta_draws is not None and len(theta_draws) > 1:
        rng = np.random.default_rng(seed)
        pick = rng.choice(len(theta_draws), min(n_draws, len(theta_draws)), replace=False)
        td, rd = transfer(model, np.asarray(theta_draws)[pick])
        ru, rr = noise_from_t(corrected(C[None], rd), td)
        var = var + np.var(np.concatenate([ru, rr], axis=-1), axis=0)
    z = NormalDist().inv_cdf(0.5 + level / 2)
    sd = np.sqrt(var)
    lo, hi = np.maximum(point - z * sd, 0.0), np.maximum(point + z * sd, 0.0)
    ident = np.r_[np.ones(nu, bool), np.full(nr, nu >= nr)]
    recorded = np.real(np.einsum("bii->ib", c0))
    return {"freq_hz": fc, "ids": list(sp.sut_ids) + list(sp.ref_ids), "n_u": nu,
            "psd": point.T, "lo": lo.T, "hi": hi.T, "sd": sd.T, "recorded": recorded,
            "identified": ident, "level": level}


def reference_margin_db(result, along, signed=False):
    """Median over bands and identified channel pairs of reference minus
    SUT self-noise in dB; ``along`` (n_r,) the SUT channel along each
    reference channel. NaN when nothing can be compared. A band where
    either estimate is not positive is left out, or with ``signed`` counted
    as an infinite margin for the other sensor (a reference noise at or
    below zero: the reference is the quieter there)."""
    nu = result["n_u"]
    diffs = []
    for k, i in enumerate(along):
        if not result["identified"][nu + k]:
            continue
        a, b = result["psd"][nu + k], result["psd"][i]
        ok = (a > 0) & (b > 0)
        d = np.full(a.shape, np.nan)
        d[ok] = db(a[ok]) - db(b[ok])
        if signed:
            d[a <= 0] = -np.inf
            d[(a > 0) & (b <= 0)] = np.inf
        diffs.append(d[~np.isnan(d)])
    diffs = np.concatenate(diffs) if diffs else np.array([])
    return float(np.median(diffs)) if diffs.size else float("nan")


def reference_margin(result, along):
    """The margin of :func:`summarise`: :func:`reference_margin_db` with a
    band where one sensor's estimate is not positive counted for the other
    (its noise is below what the split resolves there, as at the metadata
    gains), so that the bands a split does resolve do not speak for those it
    does not; where that median is unbounded (most bands unresolved on one
    side), the median over the resolved bands, if it has the same sign."""
    signed = reference_margin_db(result, along, signed=True)
    if np.isfinite(signed) or np.isnan(signed):
        return signed
    resolved = reference_margin_db(result, along)
    return resolved if np.isfinite(resolved) and np.sign(resolved) == np.sign(signed) else signed


def at_metadata_gain(model, theta, factor=1.0):
    """``theta`` with every fitted SUT gain set to its metadata value times
    ``factor`` (period, damping and angles as fitted)."""
    th = np.array(theta, dtype=float)
    for b, (_, sr) in zip(model.blocks, model.slices):
        if b.free in ("gain", "all") and b.family is not None:
            th[..., np.arange(th.shape[-1])[sr][-1]] = np.log(b.family.gain * factor)
    return th


def metadata_gain_margins_db(model, theta, along, spread=METADATA_GAIN_SPREAD):
    """Reference-minus-SUT margins (dB, :func:`reference_margin_db` with
    ``signed``) with the SUT's gains at their metadata values times
    ``1/(1+spread)``, 1 and ``1+spread``: a (3,) array.

    Why: with one axis seen by both sensors the gain and the two noises
    trade off (``S_ur = g S``, ``S_rr = S + N_r``, ``S_uu = g^2 S + N_u``),
    so a gain fitted under the quiet-reference model (``g = S_ur / S_rr``)
    puts all the incoherent power into the SUT and cannot see a noisy
    reference. At the metadata gain the split is unbiased when the metadata
    are right; a gain error ``e`` moves ``N_r`` by about ``e S``. The least of
    the three margins names a reference that is noisier whatever the
    metadata error up to ``spread``; where the noise is below about
    ``spread`` of the signal at every frequency the margins straddle the
    threshold and the order is undetermined (:func:`order_entry`)."""
    return np.array([reference_margin_db(pair_self_noise(model, at_metadata_gain(model, theta, f)),
                                         along, signed=True)
                     for f in (1.0 / (1.0 + spread), 1.0, 1.0 + spread)])


def order_entry(margins, spread=METADATA_GAIN_SPREAD, fitted_db=None):
    """``sensor_order`` of a free-gain fit from the three
    :func:`metadata_gain_margins_db`: a warning where even the least margin
    passes :data:`SWAP_MARGIN_DB`; a caution where only the margin at the
    metadata gains does (a swap, or a SUT gain below its metadata); else
    silent. A margin of None in result.json: the reference's noise is below
    what the split resolves. ``fitted_db``: under ``--ref-noise estimate``,
    the margin at the fitted gains (unbiased where the self-noise is smooth
    in frequency, as real self-noise is), which also raises the warning."""
    least, at_meta = float(np.min(margins)), float(margins[1])
    msg = swap_message(least) or (swap_message(fitted_db) if fitted_db is not None else None)
    third = ("bayescal noise with a third sensor tells them apart" if fitted_db is not None
             else "--ref-noise estimate or bayescal noise with a third sensor tells them apart")
    out = {"reference_minus_sut_db": least, "at_metadata_gains_db": at_meta,
           "reference_noisier": msg is not None, "threshold_db": SWAP_MARGIN_DB,
           "basis": (f"self-noise split at the SUT's metadata gains times 1/{1 + spread:g}, 1 "
                     f"and {1 + spread:g}, the least margin of the three (the fitted gains "
                     "absorb the reference's noise under --ref-noise quiet, and under "
                     "estimate where its noise has the ground motion's spectral shape)")}
    if fitted_db is not None:
        out["at_fitted_gains_db"] = float(fitted_db)
        out["basis"] += "; or the margin at the fitted gains (--ref-noise estimate)"
    if msg:
        out["message"] = msg
    elif at_meta > SWAP_MARGIN_DB:
        by = f"by {at_meta:.1f} dB" if np.isfinite(at_meta) else "in most bands"
        out["caution"] = (f"at the SUT's metadata gains the reference comes out the noisier "
                          f"({by}), but a gain error under {100 * spread:g} % could explain "
                          "it: either --ref and --sut are swapped or the SUT's gain is below "
                          f"its metadata; {third}")
    elif np.max(margins) >= -SWAP_MARGIN_DB:
        out["undetermined"] = ("which sensor is the noisier cannot be told from this pair: "
                               f"within a {100 * spread:g} % error of the metadata gains "
                               f"either could be; {third}")
    return out


def swap_message(margin_db):
    """The warning of a reference noisier than the SUT, or None."""
    if np.isnan(margin_db) or margin_db <= SWAP_MARGIN_DB:
        return None
    by = (f"by {margin_db:.1f} dB in the band" if np.isfinite(margin_db) else
          "in most bands (the sensor under test's noise is below what the split resolves there)")
    return f"the reference is noisier than the sensor under test {by}; were --ref and --sut swapped?"


def summarise(result, along, basis):
    """The ``self_noise`` and ``sensor_order`` entries of result.json."""
    out = {}
    lo_db, hi_db = db(result["lo"]), db(result["hi"])
    for j, cid in enumerate(result["ids"]):
        if not result["identified"][j]:
            out[cid] = {"not_identifiable": NOT_IDENTIFIABLE_REF}
            continue
        out[cid] = {"freq_hz": result["freq_hz"], "psd_db": db(result["psd"][j]),
                    f"ci{round(100 * result['level'])}_db": [lo_db[j], hi_db[j]],
                    "sd_psd": result["sd"][j], "recorded_db": db(result["recorded"][j])}
    margin = reference_margin(result, along)
    msg = swap_message(margin)
    order = {"reference_minus_sut_db": margin, "reference_noisier": msg is not None,
             "threshold_db": SWAP_MARGIN_DB}
    if msg:
        order["message"] = msg
    return {"units": "dB re 1 (m/s^2)^2/Hz, per band; a null bound: the estimate is not "
                     "positive there (upper bound only); sd_psd: the estimate's standard "
                     "deviation in (m/s^2)^2/Hz, the interval being the estimate +- its normal "
                     "quantile times sd_psd on the power scale",
            "basis": basis, "channels": out}, order


def not_identifiable(sut_ids, ref_ids):
    """The ``self_noise`` entry of a pair with one channel per sensor."""
    return {"basis": NOT_IDENTIFIABLE,
            "channels": {cid: {"not_identifiable": NOT_IDENTIFIABLE}
                         for cid in list(sut_ids) + list(ref_ids)}}


FLAT_NOTE = ("'flat' metadata: levels are in the assumed units (1 count per m/s taken as "
             "ground velocity), not in (m/s^2)^2/Hz, and with the SUT's gain held at that "
             "assumption the split of the noise between the two sensors is not meaningful "
             "(no sensor-order check)")


def for_fit(model, samples, *, ref_noise=None, free="none", seed=0, ids=((), ()), flat=False,
            sut_placeholder=False, poorly_separated=False):
    """``(self_noise, sensor_order)`` result.json entries of a pair fit:
    ``model`` the fitted model (None for a fit without one, e.g. the
    orthogonal-pair rotation), ``samples`` (N, ndim) its posterior draws in
    model coordinates; ``ids`` (SUT ids, reference ids) name the channels
    when there is no model. One channel on either side: not identifiable
    (and no sensor-order check). ``flat``: the reference's metadata, or the
    SUT's with its gain held, is the assumed flat response
    (:data:`FLAT_NOTE`; a flat SUT whose gain is fitted is put in the
    reference's ground units by that gain). With free gains under the
    quiet-reference model the sensor order is judged at the metadata gains
    (:func:`metadata_gain_margin_db`), unless the SUT's metadata are a
    placeholder (``sut_placeholder``: no gain to trust, a caution instead).
    ``poorly_separated``: under ``--ref-noise estimate`` the reference's noise
    was not told apart from the gains (:mod:`bayescal.core.checks.separation`), so
    the split at the fitted gains names no order."""
    if model is None:
        return not_identifiable(*ids), {}
    sp = model.spectra
    if sp.n_u < 2 or sp.n_r < 2:
        return not_identifiable(sp.sut_ids, sp.ref_ids), {}
    from ..threads import single_threaded_blas
    theta = np.median(samples, axis=0)
    t = transfer(model, theta)[0][0, 0]
    along = np.argmax(np.abs(t), axis=0)
    mode = ref_noise or "quiet"
    quiet_free = mode == "quiet" and free != "none"
    # free gains: the order is judged at the metadata gains in every mode;
    # under 'quiet' the fitted gains absorb the reference's noise, and under
    # 'estimate' so do they where its noise has the ground motion's own
    # spectral shape (a pair cannot tell that from a gain: S_ur / S_rr = T / (1 + x))
    with single_threaded_blas():      # small products: threads only add latency
        res = pair_self_noise(model, theta, samples, seed=seed)
        margins = (metadata_gain_margins_db(model, theta, along)
                   if free != "none" and not (sut_placeholder or flat) else None)
    basis = (f"diag(S_uu - S_ur T^H) and diag(S_rr - T^+ S_ur) with the fitted transfer T "
             f"(--ref-noise {mode}); 90 % band: Wishart variance of the band spectra plus "
             "the scatter over posterior draws of T")
    if quiet_free:
        basis += ("; caution: with free gains and --ref-noise quiet, T absorbs the reference's "
                  "noise (reference's estimate low, SUT's high); use --ref-noise estimate")
    entry, order = summarise(res, along, basis)
    order = _order(order, margins, mode=mode, free=free, poorly_separated=poorly_separated)
    if flat:
        entry["units"] = FLAT_NOTE
        if free == "none":
            order = {}
    return entry, order


def _order(order, margins, *, mode, free, poorly_separated):
    """The ``sensor_order`` entry of :func:`for_fit`: :func:`summarise`'s
    ``order`` judged at the metadata gains (``margins``, None when not
    judged there), or said undetermined or cautioned as the mode needs."""
    split_at_fit = mode in ("estimate", "fixed") and not poorly_separated
    if margins is not None:
        return order_entry(margins, fitted_db=order.get("reference_minus_sut_db")
                           if split_at_fit else None)
    if mode == "estimate" and poorly_separated and free != "none":
        return {"reference_minus_sut_db": order.get("reference_minus_sut_db"),
                "reference_noisier": False, "threshold_db": SWAP_MARGIN_DB,
                "undetermined": "which sensor is the noisier cannot be told from this pair: "
                                "its noise is poorly separated from the SUT's gains in this "
                                "band (see reference noise); bayescal noise with a third "
                                "sensor tells them apart"}
    if mode == "quiet" and free != "none":
        order["caution"] = ("free gains with --ref-noise quiet and placeholder metadata: the "
                            "gains absorb the reference's noise, so a noisier reference can go "
                            "unnoticed here")
    return order
