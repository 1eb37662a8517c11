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
5 % by default). The search offers both where both apply and keeps the one
the evidence prefers (the Laplace evidence, whose Occam factor holds each
prior's width: :func:`bayescal.criticism.search.log_evidence`). The box
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
        norm = np.array([fam.norm_freq for fam in self.families])
        new_n, nom_n = self._denominators(norm, p)
        k = np.arange(len(self.rows))
        scale = np.abs(nom_n[k, k])[None, :] / np.abs(new_n[:, k, k])        # (W, n)
        with np.errstate(all="ignore"):
            return new / nom[None] * scale[:, :, None]

    def log_prior(self, p):
        inside = np.all(np.abs(p.reshape(p.shape[0], -1, 2)) <= self.half_width, axis=(1, 2))
        return np.where(inside, -float(np.sum(np.log(2 * self.half_width))), -np.inf)

    #: Its box prior is normalised: ``log_prior`` is the density.
    def log_prior_density(self, p):
        """The normalised log prior density at ``p`` (the box's)."""
        return self.log_prior(p)

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
