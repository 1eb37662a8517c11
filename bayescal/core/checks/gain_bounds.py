"""What a pair's spectra say about each SUT gain whatever the two sensors'
self-noise: the gain's identified interval, and whether the fit's gain is
separated from the reference's noise.

For one SUT channel, let ``y`` be its record in ground units (deconvolved by
its metadata response, so ``y = g s + n_u`` with ``g`` the relative gain,
fitted / metadata) and ``x`` the reference's record projected on that
channel's fitted axis (``x = s + n_r``). With band sums ``A = S_xx``, ``P =
Re S_yx`` and ``Y = S_yy``, and both noises uncorrelated with the ground and
with each other,

    E[A] = S + N_r,   E[P] = g S,   E[Y] = g^2 S + N_u,

so, both noises being non-negative, ``P / A <= g <= Y / P`` in every band and
over any set of bands: the gain's *bounds* (:func:`bounds`). They collapse to
``g`` when both noises vanish. Between them the pair cannot place the gain
unless one sensor's noise has a known shape:

* the fit (``--ref-noise estimate``) takes the reference's noise as smooth
  (white in ground units plus white in its counts), which gives ``A = P / g +
  smooth`` (the reference side of :func:`side_gains`);
* the SUT's side gives ``Y = g P + N_u`` (:func:`side_gains`): with
  ``N_u`` smooth (white in ground units plus white in the SUT's counts) the
  regression of ``Y`` on ``P`` and the two shapes gives ``g`` whatever the
  reference's noise, and the reference's noise along the channel as a
  fraction of the ground power there, ``x = g A / P - 1`` (pooled over the
  band).

When a noise follows the ground motion's own spectrum (``N = x S``), one
of the two is wrong, and a pair cannot tell which (the two hypotheses give
identical spectra): the two estimates then disagree (their difference
against its own standard error: they share the band sums, so their errors
are strongly correlated), and the gain is *not separable*
(:func:`separation_verdict`). Its bounds are the answer a pair
gives; a third co-located sensor (``bayescal noise``, then
``--ref-noise-psd``) measures the reference's noise and removes the doubt.

Uncertainty (closed form). A band sum of ``nu`` independent complex Gaussian
samples (``nu`` the band's degrees of freedom, :func:`bayescal.core.spectra.dof.band_dof`)
has, by Isserlis' theorem, ``var A = A^2 / nu``, ``var Y = Y^2 / nu``,
``var P = (A Y + P^2 - Q^2) / (2 nu)`` (``Q = Im S_yx``), ``cov(P, A) = A P /
nu``, ``cov(P, Y) = Y P / nu``, ``cov(A, Y) = |S_yx|^2 / nu``; bands are
independent. The bounds' standard errors follow by the delta method; each
side's from its weighted normal equations; their difference's by the delta
method over all band sums.

The bounds take the SUT channel's axis from the fit: an axis the noise
leans (noise shaped like the ground in an anisotropic field) moves them by
about the cosine of the error and the field's anisotropy.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

#: Fewest bands the SUT-side regression (a gain and two noise shapes) needs.
MIN_BANDS = 4
#: The two sides' gains disagree beyond this many standard errors of their
#: difference (two-sided 1 % per channel).
DISAGREE_Z = 2.576
#: Two-sided normal quantile of the bounds' outer 95 % interval (each end one-sided 97.5 %).
Z95 = 1.959964


def band_moments(a, c, y, dof):
    """Variances and covariances of the band sums ``(A, P, Y)``: a dict of
    (B,) arrays ``AA, PP, YY, PA, PY, AY``. ``a``, ``y`` real (B,), ``c``
    complex (B,) the cross band sums ``S_yx``, ``dof`` (B,) each band's
    independent complex samples."""
    a, y, dof = np.asarray(a, float), np.asarray(y, float), np.asarray(dof, float)
    c = np.asarray(c, complex)
    p, q = c.real, c.imag
    return {"AA": a * a / dof, "YY": y * y / dof, "PP": (a * y + p * p - q * q) / (2 * dof),
            "PA": a * p / dof, "PY": y * p / dof, "AY": np.abs(c) ** 2 / dof}


def bounds(a, c, y, dof):
    """The gain's bounds ``(lower, upper, sd_lower, sd_upper)`` from band sums
    over the bands given: ``lower = sum P / sum A``, ``upper = sum Y / sum
    P``, each with its delta-method standard error (:func:`band_moments`);
    NaN when ``sum P`` is not positive. Arguments as :func:`band_moments`."""
    m = {k: v.sum() for k, v in band_moments(a, c, y, dof).items()}
    sa, sp, sy = float(np.sum(a)), float(np.sum(np.real(c))), float(np.sum(y))
    if not (sa > 0 and sp > 0):      # no positive cross-power along the axis: no bounds
        return np.nan, np.nan, np.nan, np.nan
    lower, upper = sp / sa, sy / sp
    var_l = lower ** 2 * (m["PP"] / sp ** 2 + m["AA"] / sa ** 2 - 2 * m["PA"] / (sp * sa))
    var_u = upper ** 2 * (m["YY"] / sy ** 2 + m["PP"] / sp ** 2 - 2 * m["PY"] / (sy * sp))
    return lower, upper, float(np.sqrt(max(var_l, 0.0))), float(np.sqrt(max(var_u, 0.0)))


def _regression(resp, reg, shapes, var, with_sd=True):
    """Weighted non-negative least squares of ``resp`` on ``[reg, shapes]``
    (each band weighted by ``1 / var``): the coefficient of ``reg`` and its
    standard error (from the normal equations of the columns in use; NaN
    without ``with_sd``); both NaN when a band sum, shape or weight is not
    finite."""
    sw = 1.0 / np.sqrt(np.maximum(var, 1e-300))
    shapes = shapes / shapes.mean(axis=0, keepdims=True) * resp.mean()
    design = np.column_stack([reg, shapes])
    if not (np.all(np.isfinite(design * sw[:, None])) and np.all(np.isfinite(resp * sw))):
        return np.nan, np.nan            # spectra or shapes not finite: no regression
    coef, _ = nnls(design * sw[:, None], resp * sw)
    if not with_sd:
        return float(coef[0]), np.nan
    xw = design[:, np.r_[True, coef[1:] > 0]] * sw[:, None]
    try:
        sd = float(np.sqrt(np.linalg.inv(xw.T @ xw)[0, 0]))
    except np.linalg.LinAlgError:
        sd = np.nan
    return float(coef[0]), sd


def _side_variances(m, g_u, g_r):
    """Per-band variances of ``Y - g_u P`` and ``A - P / g_r``."""
    b = 1.0 / g_r
    return (m["YY"] + g_u * g_u * m["PP"] - 2 * g_u * m["PY"],
            m["AA"] + b * b * m["PP"] - 2 * b * m["PA"])


def side_gains(a, c, y, dof, sut_shapes, ref_shapes, sweeps=3):
    """The gain from each sensor's side, each with the other's noise free.

    SUT side: the SUT's noise a non-negative combination of ``sut_shapes``
    (B, J), band sums of its spectral shapes in the units of ``y``: weighted
    non-negative least squares of ``Y = g P + sut_shapes e``, whatever the
    reference's noise. Reference side (as the fit assumes): ``A = P / g +
    ref_shapes c``. Each band is weighted by the inverse variance of its
    residual (:func:`band_moments`, at the current gain; ``sweeps`` passes).

    Returns a dict: ``sut`` and ``ref`` (gain, standard error), ``fraction``
    (the reference's noise along the channel over the ground power there,
    pooled over the bands, ``g_sut sum A / sum P - 1``), ``difference``
    (``g_sut - g_ref``) and its standard error ``difference_sd`` (delta
    method over all band sums, the two estimates' correlation included);
    None when fewer than :data:`MIN_BANDS` bands or ``sum P <= 0``."""
    a, y = np.asarray(a, float), np.asarray(y, float)
    p = np.real(np.asarray(c, complex))
    if a.size < MIN_BANDS or p.sum() <= 0:
        return None
    m = band_moments(a, c, y, dof)
    su, sr = np.asarray(sut_shapes, float), np.asarray(ref_shapes, float)
    g_u = g_r = p.sum() / a.sum()
    for _ in range(sweeps):
        var_u, var_r = _side_variances(m, g_u, g_r)
        g_u, sd_u = _regression(y, p, su, var_u)
        beta, sd_b = _regression(a, p, sr, var_r)
        g_r = 1.0 / beta if beta > 0 else np.nan
        if not (np.isfinite(g_r) and np.isfinite(g_u)):
            return None

    def diff(v):      # the weights held at their values (the delta method's convention)
        return (_regression(v[2], v[1], su, var_u, False)[0]
                - 1.0 / _regression(v[0], v[1], sr, var_r, False)[0])
    x0 = np.stack([a, p, y])
    grad, d0 = np.zeros_like(x0), diff(x0)
    for k in np.ndindex(x0.shape):       # forward differences, relative step 1e-7
        h = 1e-7 * abs(x0[k]) + 1e-300
        up = x0.copy()
        up[k] += h
        grad[k] = (diff(up) - d0) / h
    cov = np.array([[m["AA"], m["PA"], m["AY"]], [m["PA"], m["PP"], m["PY"]],
                    [m["AY"], m["PY"], m["YY"]]])                          # (3, 3, B)
    var_d = float(np.einsum("ib,ijb,jb->", grad, cov, grad))
    return {"sut": (g_u, sd_u), "ref": (g_r, sd_b / beta ** 2),
            "fraction": float(g_u * a.sum() / p.sum() - 1.0), "difference": g_u - g_r,
            "difference_sd": float(np.sqrt(max(var_d, 0.0)))}


def separation_verdict(fit, fit_sd, lower, upper, sides):
    """Whether the fit's gain ``fit`` (standard error ``fit_sd``) is separated
    from the reference's noise: True when the bounds ``lower``-``upper`` are
    within the fit's own uncertainty (``upper - lower <= 2 fit_sd``), or when
    the SUT-side gain (``sides`` as :func:`side_gains` returns) can tell the
    two ends of the bounds apart (``3 sd < (upper - lower) / 2``) and agrees
    both with the reference side (their difference within
    :data:`DISAGREE_Z` of its standard error) and with the fit (within 3
    joint standard errors); False otherwise."""
    width = upper - lower
    if not np.isfinite(width):
        return False
    if width <= 2.0 * fit_sd:
        return True
    if sides is None or not np.all(np.isfinite([*sides["sut"], sides["difference_sd"]])):
        return False
    g_u, sd_u = sides["sut"]
    if 3.0 * sd_u >= width / 2.0:
        return False
    return bool(abs(sides["difference"]) <= DISAGREE_Z * sides["difference_sd"]
                and abs(fit - g_u) <= 3.0 * np.hypot(fit_sd, sd_u))


def channel_sums(spectra, directions, factor=None):
    """Band sums ``(A, C, Y)`` per SUT channel, each (n_u, B): ``A`` the
    reference projected by ``directions`` (n_u, n_r; row ``i`` the
    combination of reference channels along SUT channel ``i``'s axis),
    ``C = S_yx`` and ``Y`` the SUT channel's power, its spectrum multiplied
    per bin by ``factor`` (n_u, F) when given."""
    nu = spectra.n_u
    tot = spectra.total
    w = np.asarray(directions)
    a = np.real(np.einsum("ik,fkl,il->if", w.conj(), tot[:, nu:, nu:], w))
    c = np.einsum("fik,ik->if", tot[:, :nu, nu:], w)
    y = np.real(np.einsum("fii->if", tot[:, :nu, :nu]))
    if factor is not None:
        c, y = c * factor, y * np.abs(factor) ** 2
    nb = spectra.n_bands

    def fold(v):
        return np.stack([np.bincount(spectra.band_of, weights=r, minlength=nb) for r in v])
    return fold(a), fold(c.real) + 1j * fold(c.imag), fold(y)


def side_shapes(spectra, directions, factor=None):
    """Band sums of the two sensors' self-noise shapes along each SUT
    channel, ``(sut, ref)``, each (n_u, B, 2): white in ground units, and
    white in the sensor's counts (``1 / |H_nom|^2``, ``f^-2`` for a channel
    already in ground units); the SUT's times ``|factor|^2`` when given, the
    reference's projected by ``directions`` (as :func:`channel_sums`)."""
    nu, nb = spectra.n_u, spectra.n_bands
    freqs = spectra.freqs
    pw = spectra.response_power
    counts = (1.0 / pw) if pw is not None else np.tile(freqs ** -2.0, (nu + spectra.n_r, 1))
    counts[np.ptp(np.log(counts), axis=1) < 0.1] = freqs ** -2.0
    w2 = np.abs(np.asarray(directions)) ** 2                                # (n_u, n_r)
    sut_counts = counts[:nu] * (1.0 if factor is None else np.abs(factor) ** 2)
    per_bin = {"sut": (np.ones((nu, freqs.size)), sut_counts),
               "ref": (np.tile(w2.sum(axis=1)[:, None], (1, freqs.size)), w2 @ counts[nu:])}
    out = []
    for side in ("sut", "ref"):
        out.append(np.stack([np.stack([np.bincount(spectra.band_of, weights=r, minlength=nb)
                                       for r in v]) for v in per_bin[side]], axis=2))
    return tuple(out)


def identified_gains(model, theta, cov):
    """``meta.reference_noise.gain_bounds`` of a pair fit: for every SUT
    channel whose gain is fitted, the relative gain's bounds with their
    standard errors and outer 95 % interval, the SUT-side gain and the
    reference's noise fraction (:func:`side_gains`), the fit's gain at
    ``theta`` (``cov`` its least-squares covariance) and whether it is
    separable (:func:`separation_verdict`). An empty dict when no gain is
    fitted. ``model`` a :class:`~bayescal.core.model.likelihood.Model` (any
    reference-noise mode)."""
    from ..spectra.dof import band_dof

    theta = np.atleast_2d(np.asarray(theta, float))[:1]
    fitted, (a, c, y), (su, sr) = _fitted_sums(model, theta, shapes=True)
    if not fitted:
        return {}
    dof = band_dof(model.spectra)
    channels = {model.blocks[i].channel_id: channel_entry(
        bounds(a[i], c[i], y[i], dof), _sides_or_none(a[i], c[i], y[i], dof, su[i], sr[i]),
        g, g * float(np.sqrt(max(cov[j, j], 0.0))))
        for i, (g, j) in fitted.items()}
    out = {"channels": channels, "basis": BASIS}
    if getattr(model, "ref_noise", "quiet") != "fixed":
        note = not_separable_note(channels)
        if note:
            out["note"] = note
    return out


def _fitted_sums(model, theta, shapes=False, held=False):
    """The fitted gains at ``theta`` (1, ndim), ``{SUT channel index: (relative
    gain, its parameter's index)}``, and the band sums :func:`channel_sums`
    gives along the fitted axes with the fitted response's shape (its gain
    left out, so that the spectra bound the relative gain itself); with
    ``shapes``, :func:`side_shapes` too (else None). With ``held``, the
    channels whose gain is held at the metadata's (``--fit-response
    none``) too, as ``(1.0, None)``."""
    sp = model.spectra
    vecs, ratio = model.unpack(theta)
    factor = ratio[0] @ model.node_weights.T                               # (n_u, F)
    fitted, values = {}, model.response_values(theta)
    for i, b in enumerate(model.blocks):
        name = f"{b.channel_id}:log_gain"
        if name in model.names and b.family is not None:
            g = float(values[b.channel_id][0, 2] / b.family.gain)
            fitted[i] = (g, model.names.index(name))
            factor[i] = factor[i] * g
        elif held and b.free == "none" and b.family is not None:
            fitted[i] = (1.0, None)
    if not fitted:
        return fitted, (None,) * 3, (None,) * 2
    directions = vecs[0] @ model.ref_pinv
    return (fitted, channel_sums(sp, directions, factor),
            side_shapes(sp, directions, factor) if shapes else (None, None))


def off_scale(model, theta):
    """The SUT channels whose gain (fitted, or held at the metadata's with
    ``--fit-response none``) the spectra place wholly outside the range of
    the gain's prior, whatever the two sensors' self-noise: ``{channel id:
    entry}``, empty when there are none.

    The relative gain lies within :func:`bounds` over the band whatever
    either sensor's noise; when even the outer 95 % interval of those bounds
    (each end one-sided 97.5 %) lies beyond the prior's range (a factor
    :func:`~bayescal.core.response.family.gain_prior_factor` either side of
    the metadata gain) by more than :data:`OFF_SCALE_MARGIN`, no gain the
    prior allows fits the recordings, by orders of magnitude: the two
    sensors' metadata disagree in scale (a stage or a unit left out), and a
    posterior would sit at the prior's bound, set by the prior alone. (Nearer
    the prior's range the fit runs, and flags the gain as pinned.)

    The axes and the response's shape are ``theta``'s. The closed-form
    start's axes (:func:`bayescal.core.fit.run.closed_form_transfer`) do not
    depend on the gains' scale, where a least-squares point with a gain held
    at the prior's bound turns the axes to shrink the misfit. Each entry
    holds ``implied`` (the geometric mean of the two bounds: the relative
    gain the spectra give), ``interval95``, ``prior`` (the range of relative
    gains the prior allows), ``fit`` (the gain at ``theta``) and ``held``
    (whether the fit holds the gain at the metadata's)."""
    from ..response.family import gain_prior_factor
    from ..spectra.dof import band_dof

    theta = np.atleast_2d(np.asarray(theta, float))[:1]
    fitted, (a, c, y), _ = _fitted_sums(model, theta, held=True)
    dof = band_dof(model.spectra) if fitted else None
    out = {}
    for i, (g, j) in fitted.items():
        lower, upper, sd_l, sd_u = bounds(a[i], c[i], y[i], dof)
        lo95, hi95 = lower - Z95 * sd_l, upper + Z95 * sd_u
        span = gain_prior_factor(model.blocks[i].family, model.priors)
        far = span * OFF_SCALE_MARGIN
        if np.isfinite(lo95) and np.isfinite(hi95) and (lo95 > far or 0 < hi95 < 1.0 / far):
            out[model.blocks[i].channel_id] = {
                "implied": float(np.sqrt(lower * upper)), "interval95": [float(lo95), float(hi95)],
                "prior": [1.0 / span, float(span)], "fit": g, "held": j is None}
    return out


def off_scale_message(channels):
    """The refusal of a fit whose gains ``channels`` (as :func:`off_scale`
    gives them) the spectra place outside the prior: each channel and the
    gain its spectra imply, which metadata to check, and what helps."""
    per = "; ".join(f"{cid} {_sci(e['implied'])} (95 %: {_sci(e['interval95'][0])} to "
                    f"{_sci(e['interval95'][1])})" for cid, e in channels.items())
    lo, hi = next(iter(channels.values()))["prior"]
    implied = float(np.exp(np.median([np.log(e["implied"]) for e in channels.values()])))
    factor = _sci(max(implied, 1.0 / implied))
    small, large = ("small", "large") if implied < 1.0 else ("large", "small")
    stage = ("(a digitizer's gain in counts per volt is of this order): check the digitizer "
             "stage" if DIGITIZER_RANGE[0] <= max(implied, 1.0 / implied) <= DIGITIZER_RANGE[1]
             else ": check the stages")
    held = any(e.get("held") for e in channels.values())
    where = (f"the prior's range ({lo:g} to {hi:g} times the metadata's)" if not held else
             f"the metadata's (held with --fit-response none; a fitted gain's prior allows "
             f"{lo:g} to {hi:g} times)")
    ends = "be held at values the data exclude" if held else "sit at the prior's bound"
    return (f"the recordings imply gains far outside {where}, whatever either sensor's "
            f"self-noise; the gains they imply over the metadata's: {per}. The two sensors' "
            f"metadata disagree in scale by about {factor}: the reference's sensitivity is that "
            f"much too {small}, or the SUT's that much too {large} {stage} of the --ref-xml and "
            "--sut-xml files, or 'flat' was given for one sensor and a full response for the "
            "other. "
            f"Nothing was sampled (the gains would {ends}). --sut-xml flat, with "
            "--fit-response gain (the default), fits the orientation and each gain without "
            "this limit")


def _sci(x):
    """``x`` with two significant digits, as ``3.8e5`` or ``2.3e-6``."""
    text = f"{x:.1e}"
    mantissa, exponent = text.split("e")
    return f"{mantissa}e{int(exponent)}" if abs(int(exponent)) > 2 else f"{x:.2g}"


#: How far beyond the gain prior's range (a factor) the spectra must place a
#: gain for :func:`off_scale`: with the default prior (a factor 10 either
#: side), gains more than 100 times from the metadata's.
OFF_SCALE_MARGIN = 10.0
#: Factors between two sensors' metadata that a missing or extra digitizer
#: stage makes (counts per volt of common digitizers: about 1e5 to 1e6).
DIGITIZER_RANGE = (1e4, 1e7)


def _sides_or_none(a, c, y, dof, sut_shapes, ref_shapes):
    """:func:`side_gains`, or None where its regressions cannot be made
    (spectra or shapes that are not finite, or a non-negative least squares
    that does not end in its iterations): the gain is then not checked."""
    try:
        with np.errstate(all="ignore"):
            return side_gains(a, c, y, dof, sut_shapes, ref_shapes)
    except RuntimeError as err:          # scipy's nnls: "Maximum number of iterations reached."
        if "iterations" not in str(err):
            raise
        return None


#: What ``identified_gains`` holds, for result.json.
BASIS = ("relative gain (fitted / metadata) bounded by the spectra whatever the two sensors' "
         "self-noise: lower = S_yx/S_xx, upper = S_yy/S_yx over the band (y the SUT channel, "
         "x the reference along its axis), interval95 each end one-sided 97.5 %; sut_side: the "
         "gain if the SUT's self-noise is white in ground units plus white in its counts, "
         "with the reference's noise along the channel as a fraction of the ground power; "
         "separable: the fit's gain agrees with it, or the bounds lie within the fit's "
         "uncertainty")


def not_separable_note(channels):
    """The console's and report's line on the channels whose gain is not
    separable (``channels`` as :func:`identified_gains` gives them), or None."""
    bad = {cid: e for cid, e in channels.items() if not e["separable"]}
    if not bad:
        return None
    parts = []
    for cid, e in bad.items():
        lo, hi = e["interval95"]
        text = (f"{cid} in [{lo:.4g}, {hi:.4g}]" if lo is not None and hi is not None else
                f"{cid} not bounded (no positive cross-power along its axis)")
        su = e["sut_side"]
        if None not in (su["gain"], su["sd"], su["reference_noise_fraction"]):
            pct = 100 * su["reference_noise_fraction"]
            text += (f" ({su['gain']:.4g} +- {su['sd']:.2g} if the SUT's self-noise is white in "
                     f"ground units plus white in its counts, the reference's noise then "
                     f"{pct:.2g} % of the ground power)")
        parts.append(text)
    return ("gain not separable from the reference's self-noise: a pair cannot tell a gain from "
            "noise that follows the ground motion, and the fit's gain (which takes the "
            "reference's noise as white in ground units and in its counts) disagrees with the "
            "gain from the SUT's side or cannot be checked against it. "
            "The spectra bound the relative gain (95 %): " + "; ".join(parts) + ". A third "
            "co-located sensor measures the reference's noise: bayescal noise, then "
            "--ref-noise-psd")


def channel_entry(bound, sides, fit, fit_sd):
    """One channel's entry of :func:`identified_gains` from its ``bound`` (as
    :func:`bounds` returns), ``sides`` (as :func:`side_gains` returns) and
    the fit's gain ``fit`` with standard error ``fit_sd``."""
    lower, upper, sd_l, sd_u = bound
    ok = separation_verdict(fit, fit_sd, lower, upper, sides)
    nan2 = (np.nan, np.nan)
    sides = sides or {"sut": nan2, "ref": nan2, "fraction": np.nan, "difference": np.nan,
                      "difference_sd": np.nan}
    return {"lower": _finite(lower), "upper": _finite(upper), "lower_sd": _finite(sd_l),
            "upper_sd": _finite(sd_u),
            "interval95": [_finite(lower - Z95 * sd_l), _finite(upper + Z95 * sd_u)],
            "fit": _finite(fit), "fit_sd": _finite(fit_sd), "separable": ok,
            "sut_side": {"gain": _finite(sides["sut"][0]), "sd": _finite(sides["sut"][1]),
                         "reference_noise_fraction": _finite(sides["fraction"])},
            "reference_side": {"gain": _finite(sides["ref"][0]), "sd": _finite(sides["ref"][1])},
            "difference_z": _finite(sides["difference"] / sides["difference_sd"])}


def _finite(v):
    return float(v) if np.isfinite(v) else None
