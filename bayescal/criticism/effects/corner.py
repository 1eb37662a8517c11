"""The SUT's low-frequency corner as the data see it: a pendulum pair whose
period and damping are not what the SUT's metadata say, with a wide prior
(:class:`SutCorner`). It applies whatever the metadata give: a two-pole
response held at its values (its null is the metadata's pendulum) or a
response with no corner at all (``flat`` metadata, a gain stage: its null
is "no corner", both coefficients 0).

Coordinates
-----------
The pendulum's denominator ``D(s) = s^2 + c1 s + c0`` (``c1 = 2 h w0``,
``c0 = w0^2``) enters the SUT's deconvolution linearly, so the effect's
parameters are its coefficients in units of the band's lowest angular
frequency ``w1 = 2 pi f_min``: ``a = c1 / w1`` and ``b = c0 / w1^2``. At
``f`` the deconvolution changes by ``1 + a (w1 / i w) - b (w1 / w)^2``
against a flat response: ``a`` is the phase the corner adds at the band's
foot and ``b`` its amplitude term; both are of order 1 where the corner
shows in the band, whatever the sensor. A band well above the corner fixes
``a`` (``damping / period = a w1 / (4 pi)``) and little of ``b``.

Prior
-----
Uniform over the box ``|a| <= A_MAX``, ``|b| <= B_MAX`` (a corner up to
``sqrt(B_MAX)`` times the band's foot, any damping up to about 2 there),
stretched to hold twice the metadata's own coefficients: wide beside the
sensor's stated tolerance (:class:`.response_parameters.ResponseParameters`,
5 % by default). The search offers both where both apply. Whether to leave
the stated prior is decided by the data: where they conflict with it
(:meth:`SutCorner.prior_conflict`, Box's prior-predictive test at the wide
corner's least-squares point, level
:data:`bayescal.criticism.prior_choice.CONFLICT_P`) the wide corner is kept;
otherwise the one the evidence prefers (the Laplace evidence, whose Occam
factor holds each prior's width:
:func:`bayescal.criticism.prior_choice.log_evidence_gain`). The evidence alone
keeps a stated prior the data put in its tail: it rewards the narrow prior
for the volume it spares, and the box's Occam factor, ``-ln(4 A_MAX
B_MAX) = -9.7`` per channel, is large.

The box is the wide prior by choice over one log-uniform in period and
damping (whose Occam factor over, say, 1-1000 s and damping 0.05-2 is
about 4 per channel): flat metadata's null (no corner, ``a = b = 0``) is
an interior point of the box and lies outside any prior on a period; and
the box's cost matters only where the data do not conflict with the
stated prior, or for the wide corner's own evidence gate against no
effect (:data:`bayescal.criticism.prior_choice.WIDE_PRIOR`), which a conflict
passes as well. The box
reaches slightly negative coefficients so that a null on its edge (flat
metadata) is an interior point for least squares; a negative ``b`` has no
period, and its period is reported as undefined.
"""
from __future__ import annotations

import numpy as np

from .base import CriticismEffect

#: The prior box's half-widths in the effect's coordinates (module docstring).
A_MAX, B_MAX = 40.0, 100.0


def _coefficients(family):
    """``(c1, c0)`` of a family's pendulum pair, or ``(0, 0)`` when it has
    none (a gain stage, ``flat`` metadata)."""
    period, damping = getattr(family, "period_s", np.nan), getattr(family, "damping", np.nan)
    if not (np.isfinite(period) and np.isfinite(damping)):
        return 0.0, 0.0
    w0 = 2 * np.pi / period
    return 2.0 * damping * w0, w0 * w0


class SutCorner(CriticismEffect):
    """The SUT's pendulum (period and damping) off its metadata, or present
    where its metadata give none, on the channels ``rows`` (held at their
    metadata response: gains only or none), with a wide prior. Parameters
    per row: ``a`` and ``b`` (module docstring). The amplitude at the
    normalisation frequency is kept (the gain, free or held, carries it)."""

    name = "sut_corner"
    #: In place of channel blocks that fit the pendulum under the stated
    #: prior (``--fit-response all``): the search holds those blocks at their
    #: metadata's pendulum (gain only) and this effect takes it up under its
    #: wide prior (:func:`bayescal.criticism.search.released`), kept only
    #: where the data conflict with the stated prior
    #: (:mod:`bayescal.criticism.prior_choice`).
    releases = False
    #: Least squares starts from several grid maxima: under the plug-in noise
    #: model of a start far from the corner the long periods weigh little,
    #: and one start can end on a ridge short of the optimum.
    multimodal = True
    #: Not dropped by the backward elimination: its evidence lies in the
    #: band's long periods, which the overdispersion a model leaves over the
    #: whole band (set where it misses most, often at the band's top) does
    #: not describe; its absence is judged by its posterior
    #: (:func:`bayescal.criticism.naming.weak_effects`).
    prunable = False

    def __init__(self, rows, families, channel_ids, fmin):
        self.rows = list(rows)
        self.families = list(families)
        self.channel_ids = list(channel_ids)
        self.w1 = 2 * np.pi * float(fmin)
        nominal = np.array([_coefficients(f) for f in self.families])          # (n, 2)
        self.nominal_ab = np.column_stack([nominal[:, 0] / self.w1,
                                           nominal[:, 1] / self.w1 ** 2])
        #: the metadata's coordinates: the effect's absence
        self.null = self.nominal_ab.ravel()
        self.half_width = np.maximum(np.array([A_MAX, B_MAX]), 2.0 * np.abs(self.nominal_ab))
        self.flat = [not np.any(n) for n in nominal]
        #: metadata without a corner (``flat``): the SUT's whole pendulum is
        #: missing from the model, as a two-pole family's is not, so the
        #: search keeps it first (its own term of the response family)
        self.first = any(self.flat)
        self.param_names = tuple(f"{c.split('.')[-1]}:{n}" for c in self.channel_ids
                                 for n in ("a", "b"))

    def grid(self):
        """Starting points: the metadata's pendulum and a grid of ``(a, b)``
        over the corners the band can show (every channel alike)."""
        pts = [(a, b) for a in (-0.03, 0.0, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.5, 1.0, 3.0)
               for b in (-0.1, 0.0, 0.1, 0.3, 1.0, 3.0)]
        return np.vstack([self.null[None]] + [np.tile(p, len(self.rows))[None] for p in pts])

    def _denominators(self, f, p):
        """``D_new(s) / w1^2`` (W, n, F) and ``D_nom(s) / w1^2`` (n, F)."""
        x = 1j * np.asarray(f, float) * 2 * np.pi / self.w1                   # s / w1
        a, b = p[:, 0::2, None], p[:, 1::2, None]
        new = x[None, None, :] ** 2 + a * x[None, None, :] + b
        an, bn = self.nominal_ab[:, 0, None], self.nominal_ab[:, 1, None]
        return new, x[None, :] ** 2 + an * x[None, :] + bn

    def factor(self, f, p):
        new, nom = self._denominators(f, p)
        # each row at its own family's normalisation frequency (the diagonal
        # of the denominators at all of them)
        x = 1j * np.array([fam.norm_freq for fam in self.families]) * 2 * np.pi / self.w1
        new_n = x[None] ** 2 + p[:, 0::2] * x[None] + p[:, 1::2]              # (W, n)
        nom_n = x ** 2 + self.nominal_ab[:, 0] * x + self.nominal_ab[:, 1]
        scale = np.abs(nom_n)[None, :] / np.abs(new_n)                         # (W, n)
        with np.errstate(all="ignore"):
            return new / nom[None] * scale[:, :, None]

    def log_prior(self, p):
        inside = np.all(np.abs(p.reshape(p.shape[0], -1, 2)) <= self.half_width, axis=(1, 2))
        return np.where(inside, -float(np.sum(np.log(2 * self.half_width))), -np.inf)

    #: Its box prior is normalised: ``log_prior`` is the density.
    def log_prior_density(self, p):
        """The normalised log prior density at ``p`` (the box's)."""
        return self.log_prior(p)

    def prior_conflict(self, p, cov, tolerances):
        """Whether the data conflict with the sensor's stated prior (log-normal
        period and damping around the metadata's with relative widths
        ``tolerances``): the prior-predictive test of Box (1980). At the
        wide-prior least-squares point ``p`` (n_params,), nearly the
        likelihood's maximum, with its covariance ``cov`` (the effect's
        block), the distance of ``p`` from the metadata's coefficients under
        the sum of the likelihood's covariance and the stated prior's
        (carried linearly to ``(a, b)``: ``da = a (d ln h - d ln T)``,
        ``db = -2 b d ln T``) is chi-square with one degree of freedom per
        coefficient of the channels whose metadata give a pendulum when the
        prior holds the truth. Returns ``{"chi2", "dof", "p_value"}`` (None
        without such channels): a small p-value is a prior the data put in
        its tail, whatever the Occam factor of the wider prior costs."""
        from scipy.stats import chi2 as chi2_dist

        pt, dt = tolerances
        two_pole = [k for k, flat in enumerate(self.flat) if not flat]
        if not two_pole:
            return None
        idx = np.ravel([[2 * k, 2 * k + 1] for k in two_pole])
        d = (np.asarray(p, float) - self.null)[idx]
        prior = np.zeros((idx.size, idx.size))
        for j, k in enumerate(two_pole):
            a, b = self.nominal_ab[k]
            jac = np.array([[-a, a], [-2.0 * b, 0.0]])              # d(a, b) / d(ln T, ln h)
            prior[2 * j:2 * j + 2, 2 * j:2 * j + 2] = jac @ np.diag([pt ** 2, dt ** 2]) @ jac.T
        total = np.asarray(cov, float)[np.ix_(idx, idx)] + prior
        chi2 = float(d @ np.linalg.solve(total, d))
        return {"chi2": chi2, "dof": int(idx.size),
                "p_value": float(chi2_dist.sf(chi2, idx.size))}

    def physical(self, p):
        """Per channel: ``damping_over_period`` (1/s, what a band above the
        corner fixes), ``corner_hz`` (the natural frequency, 0 for no
        corner or a negative ``b``) and, where every draw has a corner,
        ``period_s`` and ``damping``."""
        out = {}
        for k, cid in enumerate(self.channel_ids):
            a, b = p[:, 2 * k], p[:, 2 * k + 1]
            w0 = self.w1 * np.sqrt(np.maximum(b, 0.0))
            out[f"damping_over_period:{cid}"] = a * self.w1 / (4 * np.pi)
            out[f"corner_hz:{cid}"] = w0 / (2 * np.pi)
            if np.all(b > 0):
                out[f"period_s:{cid}"] = 2 * np.pi / w0
                out[f"damping:{cid}"] = a * self.w1 / (2 * w0)
        return out

    def sut_response(self, p, row):
        """The change of channel ``row``'s response at parameters ``p``
        (the effect's, medians), as :func:`bayescal.io.relative_response.change`
        takes it (a dict): on two-pole metadata with a corner (``b > 0``)
        the pendulum ``(period, damping)`` replacing the metadata's; else
        (``flat`` metadata, or no real period) a stage of its own, ``H /
        H_meta = D_meta(s) / D(s)``: zeros at the metadata's pendulum poles
        (two at the origin for ``flat``) and poles at the fitted pendulum's
        (rad/s), unit amplitude at the normalisation frequency. A negative
        coefficient (negative damping or restoring force: inside the box
        prior, no sensor's; where the band lies far above the corner the
        data leave ``b`` about zero) puts a pole in the right half-plane.
        A negative ``b`` is written at zero (no restoring force: a pole at
        the origin, the data's ``b`` about zero); then a negative ``a``
        with its poles mirrored into the left half-plane (``|a|``: the same
        amplitude at every frequency)."""
        k = self.rows.index(row)
        a, b = (float(x) for x in np.asarray(p, float)[2 * k:2 * k + 2])
        clipped = (", a negative restoring force written at zero" if b < 0 else "") + \
                  (", negative damping mirrored (same amplitude)" if a < 0 else "")
        a, b = abs(a), max(b, 0.0)
        q = np.array(p, float)
        q[2 * k:2 * k + 2] = a, b
        fam, cid = self.families[k], self.channel_ids[k]
        phys = {n: float(v[0]) for n, v in self.physical(q[None]).items()}
        label = (f"the SUT's pendulum as the data see it: damping/period "
                 f"{phys['damping_over_period:' + cid]:.4g} 1/s")
        if not self.flat[k] and b > 0 and a > 0:
            period, damping = phys[f"period_s:{cid}"], phys[f"damping:{cid}"]
            return {"zeros": [], "poles": [], "norm_freq": float(fam.norm_freq),
                    "gain_factor": 1.0, "pendulum": (period, damping),
                    "label": label + f", natural period {period:.5g} s, damping {damping:.4g}"
                    + clipped}
        an, bn = self.nominal_ab[k]
        zeros = np.roots([1.0, an * self.w1, bn * self.w1 ** 2])
        poles = np.roots([1.0, a * self.w1, b * self.w1 ** 2])
        return {"zeros": [complex(z) for z in zeros], "poles": [complex(q) for q in poles],
                "norm_freq": float(fam.norm_freq), "gain_factor": 1.0, "pendulum": None,
                "label": label + (f", corner {phys['corner_hz:' + cid]:.4g} Hz" if b > 0 else "")
                + clipped + " (two poles and two zeros relative to its metadata)"}

    def nominal(self):
        """The metadata values, keyed as :meth:`physical` (no period or
        damping where the metadata give no corner)."""
        out = self.physical(self.null[None])
        return {k: float(v[0]) for k, v in out.items()}

    def explain(self, med):
        parts = []
        for cid, flat in zip(self.channel_ids, self.flat):
            said = []
            for name, label, unit in (("damping_over_period", "damping/period", " 1/s"),
                                      ("period_s", "period", " s"), ("damping", "damping", "")):
                v = med.get(f"{name}:{cid}")
                if v is not None and np.isfinite(v):
                    said.append(f"{label} {v:.3g}{unit}")
            meta = "its metadata give no corner" if flat else "off its metadata's"
            parts.append(f"{cid} {', '.join(said) or 'no period measured'} ({meta})")
        return ("the SUT's low-frequency corner is not what its metadata say (its response "
                "relative to the reference's metadata turns at long periods): " + "; ".join(parts)
                + "; only damping/period is measured where the band lies well above the corner")
