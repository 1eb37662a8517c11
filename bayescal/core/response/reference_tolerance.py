"""The reference's own metadata uncertainty, carried into the SUT's response.

A pair measures the SUT's response against the reference's: the data fix
``H_sut / H_ref``, and the SUT's gain, period and damping are what that
ratio gives with the reference's metadata taken as exact (the default).
When the reference's metadata are known only to a tolerance (a relative
standard deviation of its gain, natural period and damping, each
log-normal), every posterior sample of an SUT channel's response is moved
by an independent draw of the error of the reference channel most aligned
with it (a draw that would leave the sample no pendulum is drawn again:
the error's law given that the sample stays a pendulum):

* gain: multiplied by the reference's gain error;
* period and damping: with ``w0 = 2 pi / T``, a velocity two-pole response
  well above its corner is ``H^-1 = 1 - c0 / w^2 - i c1 / w`` (``c0 =
  w0^2``, ``c1 = 2 h w0``), whose logarithm is ``-i c1 / w - q / w^2 +
  O(w^-3)`` with ``q = c0 - c1^2 / 2 = w0^2 (1 - 2 h^2)``. The logarithm of
  the ratio is the difference of the two sensors', so to that order the
  data fix ``c1_sut - c1_ref`` and ``q_sut - q_ref``: the SUT's ``c1`` and
  ``q`` move by the reference's error in each, and ``T``, ``h`` follow.
  Exact to second order in ``f0 / f`` (the regime where a pair cannot fix
  period and damping separately); where the band reaches the corners it is
  an approximation (``docs/validation/hard_posteriors.md`` checks it there).

Angles are not touched (the reference's orientation error is another
matter). The draws are seeded: the result is reproducible. A model
criticism judges how far its improved model moves the estimates on the
data's own intervals, before this widening (the reference's error moves
both models alike); both posteriors are widened afterwards.
"""
from __future__ import annotations

import numpy as np


def _coefficients(period, damping):
    """(c1, q) of a two-pole response."""
    w0 = 2 * np.pi / np.asarray(period, float)
    h = np.asarray(damping, float)
    return 2 * h * w0, w0 * w0 * (1 - 2 * h * h)


#: Draws of the reference's error a sample may take before it is left
#: unmoved (:func:`widen`).
MAX_REDRAWS = 50


def _period_damping(c1, q):
    w0 = np.sqrt(q + 0.5 * c1 * c1)
    return 2 * np.pi / w0, c1 / (2 * w0)


def _shift(reference, eps):
    """The reference's error in ``(c1, q)`` for the relative errors ``eps``
    (columns: period, damping)."""
    t_r, h_r = reference
    c1_r, q_r = _coefficients(t_r, h_r)
    c1_t, q_t = _coefficients(t_r * np.exp(eps[:, 0]), h_r * np.exp(eps[:, 1]))
    return c1_t - c1_r, q_t - q_r


def widen(samples, reference, tolerance, rng):
    """(N, 3) period, damping, gain samples of one SUT channel with the
    reference's metadata error drawn into them (module docstring).

    ``reference``: the aligned reference channel's nominal ``(period,
    damping)``, or None when its response is not a two-pole pendulum (then
    only the gain moves); ``tolerance``: relative standard deviation of the
    reference's gain, period and damping. A draw of the period and damping
    error that would leave a sample without a pendulum (``w0^2 <= 0``) is
    drawn again."""
    out = np.array(samples, float, copy=True)
    n = out.shape[0]
    eps = tolerance * rng.standard_normal((n, 3))
    out[:, 2] *= np.exp(eps[:, 2])
    if reference is not None and np.all(np.isfinite(out[:, :2])):
        c1, q = _coefficients(out[:, 0], out[:, 1])
        dc1, dq = _shift(reference, eps[:, :2])
        # a draw that leaves no pendulum (w0^2 = q + c1^2 / 2 <= 0) is no
        # possible reference: drawn again (the error's law conditioned on a
        # pendulum); a sample still without one after MAX_REDRAWS is not moved
        bad = q + dq + 0.5 * (c1 + dc1) ** 2 <= 0
        for _ in range(MAX_REDRAWS):
            if not bad.any():
                break
            dc1[bad], dq[bad] = _shift(reference, tolerance * rng.standard_normal((bad.sum(), 2)))
            bad = q + dq + 0.5 * (c1 + dc1) ** 2 <= 0
        moved = ~bad
        out[moved, 0], out[moved, 1] = _period_damping(c1[moved] + dc1[moved], q[moved] + dq[moved])
    return out


def aligned_reference(sut_vectors, ref_vectors):
    """Per SUT channel the index of the reference channel most aligned with it."""
    return np.argmax(np.abs(np.asarray(sut_vectors) @ np.asarray(ref_vectors).T), axis=1)


def widen_responses(response, channel_ids, *, sut_vectors, ref_vectors, ref_families,
                    tolerance, seed=0):
    """A fit's responses (channel id -> (N, 3)) with the reference's metadata
    ``tolerance`` drawn into every one (:func:`widen`); the input is left
    as it is. ``sut_vectors`` in the order of ``channel_ids``;
    ``ref_families`` per reference channel (a
    :class:`bayescal.core.response.TwoPoleFamily` or anything else)."""
    rng = np.random.default_rng([seed, 0x7EF])
    along = aligned_reference(sut_vectors, ref_vectors)
    out = dict(response)
    for k, cid in enumerate(channel_ids):
        if cid not in response:
            continue
        fam = ref_families[along[k]]
        ref = ((fam.period_s, fam.damping) if np.isfinite(getattr(fam, "period_s", np.nan))
               else None)
        out[cid] = widen(response[cid], ref, tolerance, rng)
    return out


def meta_entry(tolerance):
    """The ``reference_tolerance`` meta entry of a fit widened by ``tolerance``."""
    return {"relative_sd": float(tolerance),
            "note": "the reference's gain, natural period and damping known to this relative "
                    "standard deviation (log-normal): each SUT channel's response intervals "
                    "carry the error of the reference channel most aligned with it"}
