"""The reference's own metadata uncertainty, carried into the SUT's response.

A pair measures the SUT's response against the reference's: the data fix
``H_sut / H_ref``, and the SUT's gain, period and damping are what that
ratio gives with the reference's metadata taken as exact (the default).
When the reference's metadata are known only to a tolerance (a relative
standard deviation of its gain, natural period and damping, each
log-normal), the SUT's response is given with that error integrated out.

**What the data fix.** In the coordinates ``z = (ln g, c1, q)`` of a
channel the data fix the difference of the two sensors':

* gain: ``ln g_sut - ln g_ref``;
* period and damping: with ``w0 = 2 pi / T``, a velocity two-pole response
  well above its corner is ``H^-1 = 1 - c0 / w^2 - i c1 / w`` (``c0 =
  w0^2``, ``c1 = 2 h w0``), whose logarithm is ``-i c1 / w - q / w^2 +
  O(w^-3)`` with ``q = c0 - c1^2 / 2 = w0^2 (1 - 2 h^2)``. The logarithm of
  the ratio is the difference of the two sensors', so to that order the
  data fix ``c1_sut - c1_ref`` and ``q_sut - q_ref``. Exact to second
  order in ``f0 / f`` (the regime where a pair cannot fix period and
  damping separately); where the band reaches the corners it is an
  approximation (``docs/validation/hard_posteriors.md`` checks it there).

**The posterior.** The fit takes the reference at its metadata ``m``: its
samples follow ``p(z) ~ pi(z) L(z - m)``, ``pi`` the SUT's prior. The
reference's truth is ``m + d``, ``d = z_ref(e) - z_ref(0)`` for the
reference's relative errors ``e ~ N(0, tol^2)`` (gain, period, damping).
The SUT's posterior with the reference's error integrated out is
``p*(z) ~ pi(z) E_d[L(z - m - d)]``, the marginal of ``p*(z, d) ~ pi(z)
L(z - m - d) p(d)``. A fit sample ``z_i`` moved by an independent draw,
``z' = z_i + d``, gives the pair ``(z', d)`` the density ``pi(z' - d)
L(z' - d - m) p(d)`` (a translation: its Jacobian is 1), so its importance
weight toward ``p*`` is

    w = pi(z') / pi(z_i),

and the moved samples resampled by these weights follow ``p*``: the SUT's
prior acts on the moved values, as in a fit that samples the reference's
error itself.

**The prior in these coordinates.** The gain's log-uniform prior is flat in
``ln g``: weight 1 inside its range, 0 outside. The period and damping
priors (log-normal in ``T`` and ``h``, :mod:`.pendulum`) carried to
``(c1, q)``: with ``a = ln w0 = ln 2 pi - ln T`` and ``b = ln h``,
``dc1 = c1 (da + db)``, ``dq = 2 q da - 4 w0^2 h^2 db``, so
``|d(c1, q) / d(ln T, ln h)| = |-4 c1 w0^2 h^2 - 2 q c1| = 2 c1 w0^2 = 4 h
w0^3``, and ``ln pi(c1, q) = -x^2 / 2 sT^2 - y^2 / 2 sh^2 + 3 x - y +
const`` (``x = ln T / T_nom``, ``y = ln h / h_nom``). This is the density
the sampler uses in ``(c0_rel, c1_rel)`` (:func:`.pendulum.log_prior`):
``(c0, c1) -> (c1, q = c0 - c1^2 / 2)`` has Jacobian 1 and ``c0_rel``,
``c1_rel`` are ``c0``, ``c1`` over constants. A draw that leaves a sample
no pendulum (``w0^2 <= 0``) or a negative damping lies outside the prior:
its weight is 0, so sample and draw are conditioned jointly.

**The prior the fit samples with.** The same holds when the fit samples
``z`` with a prior ``pi_s`` other than the stated ``pi``: the pair's
density is then ``pi_s(z' - d) L(z' - d - m) p(d)``, and the weight
``pi(z') / pi_s(z_i)``. This matters where the data fix ``z`` no better
than the SUT's prior and the reference's error is wider than that prior (a
360-s SUT beside a 120-s reference): the fit's samples, held by ``pi``,
cover only the middle of what the reference's error allows, the weights'
variance is infinite and a few samples carry them all. The fit then samples
with the period and damping tolerances widened by the reference's error
mapped into the SUT's ``(ln T, ln h)`` (:func:`sampling_tolerances`), so
that its samples cover the posterior, and the weights take the stated
prior back.

Where a channel's prior is flat in the moved coordinates (its gain alone
free, or no prior given) every weight is 1 and each sample is moved by one
draw. Otherwise each sample takes several draws (:data:`DRAWS`) and the
channel's samples are resampled (systematic resampling, seeded) from that
pool by their weights; the Kish effective share of the pool's draws
(``kish_fraction``) says how much of the reference's error the SUT's prior
allows: small (below :data:`MIN_KISH`), the reference's tolerance is far
wider than the SUT's prior, which then sets the period and damping; their
number (``effective_draws``) is how many draws the intervals rest on. A
parameter held at its nominal value (its prior a point) is not moved.
Each channel is resampled on its own (its weights hold only its own
parameters and draw): its marginal is the posterior's where the fit does
not correlate its response with another channel's; the rows of two
channels' responses (and of the angles) are then not one joint sample.

Angles are not touched (the reference's orientation error is another
matter). The draws are seeded: the result is reproducible. A model
criticism judges how far its improved model moves the estimates on the
data's own intervals, before this widening (the reference's error moves
both models alike); both posteriors are widened afterwards.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import pendulum

#: Draws of the reference's error per sample where the SUT's prior weighs
#: them: as many as a pool of :data:`POOL` rows allows, within these bounds.
DRAWS = (8, 64)
#: Rows of the pool of moved samples a channel's draws fill (memory).
POOL = 1 << 20
#: Kish effective share of the draws below which the reference's tolerance
#: is called far wider than the SUT's prior.
MIN_KISH = 0.1
#: Factor on the variance of the reference's error, mapped into the SUT's
#: log period and damping, added to the prior the fit samples with
#: (:func:`sampling_tolerances`): more than 1, so that the samples' spread
#: exceeds the posterior's in every direction.
SAMPLING_INFLATION = 1.5


@dataclass(frozen=True)
class SutPrior:
    """One SUT channel's prior on its response, as the fit stated it.

    ``free``: ``"all"``, ``"gain"`` or ``"none"`` (what was sampled; a held
    value is not moved); ``log_gain``: the range of the gain's log-uniform
    prior (natural log); ``nominal``: the metadata's ``(period, damping)``
    and ``tolerance`` their log-normal priors' relative standard deviations
    (used when ``free`` is ``"all"``).
    """

    free: str = "all"
    log_gain: tuple = (-np.inf, np.inf)
    nominal: tuple | None = None
    tolerance: tuple | None = None

    @property
    def flat(self):
        """Whether the prior is flat in every coordinate that moves."""
        return self.free != "all" or self.nominal is None

    def log_density(self, rows):
        """Log density (up to a constant) at ``(period, damping, gain)`` rows
        (N, 3), in ``(c1, q, ln g)`` (module docstring); ``-inf`` outside
        the prior (no pendulum, negative damping, gain out of range)."""
        rows = np.asarray(rows, float)
        with np.errstate(invalid="ignore", divide="ignore"):
            lg = np.log(rows[:, 2])
        inside = (lg >= self.log_gain[0]) & (lg <= self.log_gain[1])
        out = np.where(inside, 0.0, -np.inf)
        if self.free == "all":
            ok = np.isfinite(rows[:, 0]) & np.isfinite(rows[:, 1])
            out = np.where(ok, out, -np.inf)
            if self.nominal is not None:
                c0, c1 = pendulum.from_physical(rows[:, 0], rows[:, 1], *self.nominal)
                out = out + pendulum.log_prior(c0, c1, *self.tolerance)
        return out


def sut_priors(model, priors=None):
    """``{channel id: SutPrior}`` of a pair model (anything with ``blocks``
    and ``priors``, as :class:`bayescal.core.model.likelihood.Model`) under
    its own priors or under ``priors`` (a
    :class:`bayescal.core.priors.Priors`: the stated ones, where the fit
    sampled with others); None when it has none (every channel's prior then
    counts as flat)."""
    blocks = getattr(model, "blocks", None)
    priors = priors or getattr(model, "priors", None)
    if blocks is None or priors is None:
        return None
    out = {}
    for b in blocks:
        fam = b.family
        if fam is None or b.free == "none":
            out[b.channel_id] = SutPrior(free="none")
            continue
        lo, hi = b.response_bounds(priors)
        two_pole = b.free == "all" and np.isfinite(getattr(fam, "period_s", np.nan))
        out[b.channel_id] = SutPrior(
            free=b.free, log_gain=(float(lo[-1]), float(hi[-1])),
            nominal=(fam.period_s, fam.damping) if two_pole else None,
            tolerance=(priors.period_tolerance, priors.damping_tolerance))
    return out


def _coefficients(period, damping):
    """(c1, q) of a two-pole response."""
    w0 = 2 * np.pi / np.asarray(period, float)
    h = np.asarray(damping, float)
    return 2 * h * w0, w0 * w0 * (1 - 2 * h * h)


def _period_damping(c1, q):
    """(period, damping) of ``(c1, q)``; NaN where ``w0^2 = q + c1^2 / 2 <= 0``."""
    c0 = q + 0.5 * c1 * c1
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.sqrt(np.where(c0 > 0, c0, np.nan))
    return 2 * np.pi / w0, c1 / (2 * w0)


def _shift(reference, eps):
    """The reference's error in ``(c1, q)`` for the relative errors ``eps``
    (columns: period, damping)."""
    t_r, h_r = reference
    c1_r, q_r = _coefficients(t_r, h_r)
    c1_t, q_t = _coefficients(t_r * np.exp(eps[:, 0]), h_r * np.exp(eps[:, 1]))
    return c1_t - c1_r, q_t - q_r


def _log_jacobian(period, damping):
    """``d(c1, q) / d(ln T, ln h)`` (2, 2) at a period and damping."""
    c1, q = _coefficients(period, damping)
    w0sq = (2 * np.pi / period) ** 2
    return np.array([[-c1, c1], [-2 * q, -4 * w0sq * damping ** 2]])


def sampling_tolerances(tolerance, pairs, period_tol, damping_tol):
    """The period and damping tolerances the fit samples with when the
    reference's metadata are known to ``tolerance`` (module docstring):
    the stated ``period_tol`` and ``damping_tol`` with
    :data:`SAMPLING_INFLATION` times the variance of the reference's error
    in ``(c1, q)``, carried into the SUT's ``(ln T, ln h)``, added (the
    largest over ``pairs``, ``((T_sut, h_sut), (T_ref, h_ref))`` nominal
    values of each SUT channel and its aligned reference channel)."""
    var = np.zeros(2)
    for sut, ref in pairs:
        m = np.linalg.solve(_log_jacobian(*sut), _log_jacobian(*ref))
        var = np.maximum(var, tolerance ** 2 * np.diag(m @ m.T))
    return (float(np.sqrt(period_tol ** 2 + SAMPLING_INFLATION * var[0])),
            float(np.sqrt(damping_tol ** 2 + SAMPLING_INFLATION * var[1])))


def moved(samples, reference, eps, pendulum_moves=True):
    """(N, 3) period, damping, gain ``samples`` moved by the reference's
    relative errors ``eps`` (N, 3: period, damping, gain): the gain
    multiplied by ``exp(eps_gain)``, ``c1`` and ``q`` shifted by the
    reference's error in them (module docstring). ``reference``: its
    nominal ``(period, damping)``, or None when its response is not a
    two-pole pendulum (then only the gain moves); ``pendulum_moves`` False:
    only the gain moves. A row left no pendulum gets a NaN period and
    damping."""
    out = np.array(samples, float, copy=True)
    out[:, 2] *= np.exp(eps[:, 2])
    if pendulum_moves and reference is not None and np.all(np.isfinite(out[:, :2])):
        c1, q = _coefficients(out[:, 0], out[:, 1])
        dc1, dq = _shift(reference, eps[:, :2])
        out[:, 0], out[:, 1] = _period_damping(c1 + dc1, q + dq)
    return out


def systematic(weights, n, rng):
    """``n`` indices into ``weights`` by systematic resampling (one uniform
    draw from ``rng``), in increasing order."""
    cw = np.cumsum(weights)
    cw /= cw[-1]
    return np.minimum(np.searchsorted(cw, (rng.uniform() + np.arange(n)) / n, side="right"),
                      len(weights) - 1)


def widen(samples, reference, tolerance, rng, prior=None, sampled=None):
    """(N, 3) period, damping, gain samples of one SUT channel with the
    reference's metadata error integrated out (module docstring).

    Parameters
    ----------
    samples : (N, 3) array
        The fit's samples (the reference taken as exact).
    reference : tuple or None
        The aligned reference channel's nominal ``(period, damping)``, or
        None when its response is not a two-pole pendulum (only the gain
        moves).
    tolerance : float
        Relative standard deviation of the reference's gain, period and
        damping.
    rng : numpy.random.Generator
    prior : SutPrior or None
        The channel's stated prior; None: flat in every moved coordinate.
    sampled : SutPrior or None
        The prior the fit sampled with (None: ``prior``).

    Returns
    -------
    (out, info)
        ``out`` (N, 3) the widened samples; ``info`` ``{"kish_fraction":
        Kish effective share of the weighted draws, "effective_draws": that
        number of draws, "draws_per_sample": draws per sample}``.
    """
    samples = np.asarray(samples, float)
    prior = prior or SutPrior(free="all")
    sampled = sampled or prior
    n = samples.shape[0]
    flat = prior.flat and sampled.flat
    draws = 1 if flat else int(np.clip(POOL // max(n, 1), *DRAWS))
    pool = np.repeat(samples, draws, axis=0)
    out = moved(pool, reference, tolerance * rng.standard_normal((n * draws, 3)),
                pendulum_moves=prior.free == "all")
    logw = prior.log_density(out) - (0.0 if flat else np.repeat(
        sampled.log_density(samples), draws))
    logw = np.where(np.isfinite(logw), logw, -np.inf)
    if not np.isfinite(logw).any():
        raise ValueError("no draw of the reference's error is allowed by the SUT's prior")
    w = np.exp(logw - logw.max())
    ess = float(w.sum() ** 2 / np.sum(w * w))
    info = {"kish_fraction": ess / w.size, "effective_draws": ess, "draws_per_sample": draws}
    if draws > 1 or not np.all(w == 1.0):
        out = out[systematic(w, n, rng)]
    return out, info


def aligned_reference(sut_vectors, ref_vectors):
    """Per SUT channel the index of the reference channel most aligned with it."""
    return np.argmax(np.abs(np.asarray(sut_vectors) @ np.asarray(ref_vectors).T), axis=1)


def _pendulum(family):
    """A family's nominal ``(period, damping)``, or None when it has none."""
    t = getattr(family, "period_s", np.nan)
    return (t, family.damping) if np.isfinite(t) else None


def pendulum_pairs(families, sut_vectors, ref_vectors, ref_families):
    """``((T_sut, h_sut), (T_ref, h_ref))`` of each SUT channel with a
    pendulum and its aligned reference channel with one
    (:func:`sampling_tolerances`)."""
    along = aligned_reference(sut_vectors, ref_vectors)
    pairs = [(_pendulum(f), _pendulum(ref_families[k])) for f, k in zip(families, along)]
    return [(s, r) for s, r in pairs if s is not None and r is not None]


def widen_responses(response, channel_ids, *, sut_vectors, ref_vectors, ref_families,
                    tolerance, seed=0, priors=None, sampled=None):
    """A fit's responses (channel id -> (N, 3)) with the reference's metadata
    ``tolerance`` integrated out of every one (:func:`widen`); the input is
    left as it is. ``sut_vectors`` in the order of ``channel_ids``;
    ``ref_families`` per reference channel (a
    :class:`bayescal.core.response.TwoPoleFamily` or anything else);
    ``priors`` ``{channel id: SutPrior}`` (:func:`sut_priors`; None: flat),
    the stated ones, ``sampled`` those the fit sampled with (None:
    ``priors``). Returns ``(responses, info)``, ``info`` per channel
    :func:`widen`'s."""
    rng = np.random.default_rng([seed, 0x7EF])
    along = aligned_reference(sut_vectors, ref_vectors)
    out, info = dict(response), {}
    for k, cid in enumerate(channel_ids):
        if cid not in response:
            continue
        ref = _pendulum(ref_families[along[k]])
        out[cid], info[cid] = widen(response[cid], ref, tolerance, rng,
                                    (priors or {}).get(cid), (sampled or priors or {}).get(cid))
    return out, info


def judged_sensitivity(response, priors, n_eff):
    """What the prior sets among the reported periods and dampings
    (``response``, channel id -> (N, 3), the tolerance integrated in): the
    prior acts on them (module docstring), so the rule of
    :func:`.pendulum.reweighted_sensitivity` reweights them to the halved
    and doubled prior at their own values, and its Fisher fallback takes
    the likelihood from their spread (posterior precision less the
    prior's). ``priors`` ``{channel id: SutPrior}``; ``n_eff`` ``{channel
    id: effective number of independent draws}``. Returns that function's
    answer for every channel whose period and damping are free."""
    out = {}
    for cid, prior in (priors or {}).items():
        if cid not in response or prior.free != "all" or prior.nominal is None:
            continue
        r = np.asarray(response[cid], float)
        c0, c1 = pendulum.from_physical(r[:, 0], r[:, 1], *prior.nominal)
        out.update(pendulum.reweighted_sensitivity(
            np.column_stack([c0, c1]), {cid: (0, 1)}, *prior.tolerance, n_eff=n_eff.get(cid)))
    return out


def meta_entry(tolerance, info=None, sampled_with=None):
    """The ``reference_tolerance`` meta entry of a fit widened by
    ``tolerance``; ``info`` per channel :func:`widen`'s (its Kish share
    under ``kish_fraction``, its effective draws under ``effective_draws``);
    ``sampled_with`` the period and damping tolerances the fit sampled with
    when not the stated ones (:func:`sampling_tolerances`)."""
    entry = {"relative_sd": float(tolerance),
             "note": "the reference's gain, natural period and damping known to this relative "
                     "standard deviation (log-normal): each SUT channel's response intervals "
                     "carry the error of the reference channel most aligned with it, weighed "
                     "by the SUT's own prior"}
    if info:
        entry["kish_fraction"] = {cid: round(float(v["kish_fraction"]), 4)
                                  for cid, v in info.items()}
        entry["effective_draws"] = {cid: int(v["effective_draws"]) for cid, v in info.items()}
    if sampled_with:
        entry["sampled_with"] = {"period_tolerance": round(float(sampled_with[0]), 4),
                                 "damping_tolerance": round(float(sampled_with[1]), 4)}
    return entry
