"""Parametrisation of a channel's response for coil calibration: the
long-period pole pair (period, damping), the first-stage gain and the
high-frequency poles and zeros of the nominal response that the band reaches.

The response is the nominal one with the free parts replaced, so

    H(f; theta) / H_nom(f) = rho_lp(f; T, h, G) * prod_k phi_k(f) / |prod_k phi_k(f_n)|,

with ``rho_lp`` :meth:`bayescal.core.response.family.TwoPoleFamily.ratio` (gain and
pendulum pair, normalised at the first stage's normalisation frequency
``f_n``) and, per free high-frequency pole ``q`` (nominal ``q0``, its
conjugate tied to it), ``phi = (s - q0)(s - q0*) / ((s - q)(s - q*))`` (one
factor for a real pole; the inverse for a zero). Dividing by ``|prod phi(f_n)|``
keeps the gain's StationXML meaning (the stage's gain at ``f_n``).

Which poles and zeros are free: those of stage 1 other than the two
long-period poles and the zeros at the origin whose frequency ``|q| / 2 pi``
is at most ``HF_REACH`` times the band's upper edge (above that they change
the response in the band by less than about a part in ten thousand in
amplitude per per cent of pole shift). Each is sampled as
``q / |q0|`` (real and imaginary part, the imaginary part only for a
complex pair), within ``HF_RANGE`` of its nominal value and in the left
half-plane.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.response import (NAMES as PENDULUM_NAMES, to_physical as pendulum_to_physical,
                             TwoPoleFamily, pendulum_coefficients, transfer)
from ..core.priors import Priors
from ..errors import FitError, InputError

#: A pole or zero is free when its frequency is at most this times the band's top.
HF_REACH = 3.0
#: Half-width of the uniform prior on each free coordinate ``q / |q0|``.
HF_RANGE = 0.5
FITS = ("lp", "hf", "all")


@dataclass(frozen=True)
class HFItem:
    """One free high-frequency pole or zero (rad/s, imaginary part >= 0)."""

    kind: str            # "pole" or "zero"
    nominal: complex
    index: int           # position in the stage's list (of the one with Im >= 0)
    conj_index: int      # position of its conjugate (-1 for a real one)

    @property
    def complex_pair(self):
        return self.conj_index >= 0

    @property
    def n_params(self):
        return 2 if self.complex_pair else 1

    @property
    def freq_hz(self):
        return abs(self.nominal) / (2 * np.pi)


def _stage_roots(response):
    st = response.response_stages[0]
    scale = 2 * np.pi if "HERTZ" in str(st.pz_transfer_function_type).upper() else 1.0
    return (np.array([complex(p) for p in st.poles]) * scale,
            np.array([complex(z) for z in st.zeros]) * scale)


def _pair_up(values, kind, skip):
    """HFItems from a list of roots: conjugate pairs tied, ``skip`` indices left out."""
    items, used = [], set(skip)
    for i, v in enumerate(values):
        if i in used:
            continue
        used.add(i)
        j = -1
        if abs(v.imag) > 1e-9 * abs(v):
            cands = [k for k in range(len(values)) if k not in used
                     and abs(values[k] - v.conjugate()) <= 1e-6 * abs(v)]
            if cands:
                j = cands[0]
                used.add(j)
            if v.imag < 0 and j >= 0:
                i, j = j, i
        items.append(HFItem(kind, complex(values[i].real, abs(values[i].imag)), i, j))
    return items


def hf_items(response, fmax):
    """The stage-1 poles and zeros a band reaching ``fmax`` Hz can see (see
    the module docstring), lowest first."""
    poles, zeros = _stage_roots(response)
    lp = list(np.argsort(np.abs(poles))[:2])
    origin = [i for i, z in enumerate(zeros) if abs(z) < 1e-6]
    items = _pair_up(poles, "pole", lp) + _pair_up(zeros, "zero", origin)
    items = [it for it in items if it.freq_hz <= HF_REACH * fmax]
    return sorted(items, key=lambda it: it.freq_hz)


@dataclass
class PZSpec:
    """Which parameters are free and how ``theta`` maps to the response ratio.

    ``theta`` is ``(c0_rel, c1_rel, ln G)`` for ``fit="lp"``, ``(ln G,
    hf...)`` for ``"hf"`` and ``(c0_rel, c1_rel, ln G, hf...)`` for
    ``"all"``: the pendulum pair in the coordinates the data see, relative to
    the nominal period and damping (:mod:`bayescal.core.response.pendulum`; its prior,
    log-normal in period and damping with the tolerances of ``priors``, is
    the model's); ``hf`` holds ``Re q / |q0|`` (and ``Im q / |q0|`` for a
    pair) per item. The gain's prior is log-uniform within
    ``priors.gain_factor`` of nominal, each ``hf`` coordinate's uniform
    within ``HF_RANGE`` of nominal.
    """

    family: TwoPoleFamily
    fit: str
    items: list
    priors: Priors = Priors()

    @classmethod
    def from_response(cls, response, fit, fmax, source="", priors=Priors()):
        if fit not in FITS:
            raise InputError(f"--fit must be one of {', '.join(FITS)}, not {fit!r}")
        fam = TwoPoleFamily.from_response(response)
        items = hf_items(response, fmax) if fit != "lp" else []
        if fit != "lp" and not items:
            raise InputError(f"{source}: the band (up to {fmax:g} Hz) reaches no high-frequency "
                             f"pole or zero of the nominal response (none below "
                             f"{HF_REACH:g} x {fmax:g} Hz): use --fit lp or a higher band")
        return cls(fam, fit, items, priors)

    @property
    def has_lp(self):
        return self.fit in ("lp", "all")

    @property
    def i_gain(self):
        return 2 if self.has_lp else 0

    @property
    def pendulum_index(self):
        """Index of ``c0_rel`` in ``theta`` (None when the pair is not fitted)."""
        return 0 if self.has_lp else None

    @property
    def names(self):
        out = list(PENDULUM_NAMES) if self.has_lp else []
        out.append("log_gain")
        for k, it in enumerate(self.items):
            out += [f"{it.kind}{k}_re"] + ([f"{it.kind}{k}_im"] if it.complex_pair else [])
        return tuple(out)

    @property
    def ndim(self):
        return len(self.names)

    def nominal_theta(self):
        fam = self.family
        out = [1.0, 1.0] if self.has_lp else []
        out.append(np.log(fam.gain))
        for it in self.items:
            q = it.nominal / abs(it.nominal)
            out += [q.real] + ([q.imag] if it.complex_pair else [])
        return np.array(out)

    def bounds(self):
        fam, pr = self.family, self.priors
        lo, hi = [], []
        if self.has_lp:             # c0_rel, c1_rel > 0: the prior is the pendulum's
            lo += [0.0, 0.0]
            hi += [np.inf, np.inf]
        lo.append(np.log(fam.gain / pr.gain_factor))
        hi.append(np.log(fam.gain * pr.gain_factor))
        for it in self.items:
            q = it.nominal / abs(it.nominal)
            lo.append(q.real - HF_RANGE)
            hi.append(min(q.real + HF_RANGE, -1e-3))
            if it.complex_pair:
                lo.append(max(q.imag - HF_RANGE, 0.0))
                hi.append(q.imag + HF_RANGE)
        return np.array(lo), np.array(hi)

    def roots(self, theta):
        """(W, n_items) complex free poles/zeros (rad/s) from ``theta`` (W, ndim)."""
        theta = np.atleast_2d(theta)
        j = self.i_gain + 1
        out = []
        for it in self.items:
            re = theta[:, j]
            im = theta[:, j + 1] if it.complex_pair else np.zeros_like(re)
            out.append((re + 1j * im) * abs(it.nominal))
            j += it.n_params
        return np.stack(out, axis=1) if out else np.zeros((theta.shape[0], 0), complex)

    def free_factors(self, s, q):
        """Product of the free factors at ``s`` (F,) for roots ``q`` (W, K): (W, F),
        each root moved from its nominal value to ``q``
        (:func:`bayescal.core.response.transfer` with one set of roots per row)."""
        w = q.shape[0]
        moved = {"pole": ([], []), "zero": ([], [])}     # (nominal, free) columns
        for k, it in enumerate(self.items):
            nominal, free = moved[it.kind]
            pairs = [(it.nominal, q[:, k])] + ([(np.conj(it.nominal), np.conj(q[:, k]))]
                                               if it.complex_pair else [])
            for q0, qk in pairs:
                nominal.append(np.full(w, q0, complex))
                free.append(qk)
        (p_nom, p_free), (z_nom, z_free) = moved["pole"], moved["zero"]
        return transfer(s, _columns(p_nom + z_free, w), _columns(p_free + z_nom, w))

    def ratio(self, freqs, theta):
        """``H(f; theta) / H_nom(f)``, shape (W, F)."""
        theta = np.atleast_2d(theta)
        fam = self.family
        f = np.asarray(freqs, float)
        if self.has_lp:
            t, h = self.period_damping(theta)
        else:
            t, h = np.full(theta.shape[0], fam.period_s), np.full(theta.shape[0], fam.damping)
        r = fam.ratio(f, t, h, np.exp(theta[:, self.i_gain]))
        if self.items:
            q = self.roots(theta)
            r = r * self.free_factors(2j * np.pi * f, q) / np.abs(
                self.free_factors(np.array([2j * np.pi * fam.norm_freq]), q))
        return r

    def polynomials(self, theta):
        """The factors of ``ratio`` that depend on ``theta`` (W, ndim) as real
        polynomials in ``s``, lowest power first: ``P`` (W, p) holds the
        pendulum denominator (when the pair is fitted) and the free poles'
        factors, ``Z`` (W, z) the free zeros' factors, so that

            ratio(s) = (G / G_nom) C(s) / |C(s_n)| * Z(s) / P(s) * |P(s_n) / Z(s_n)|

        with ``C`` the constant factors (:meth:`constant_factor`)."""
        theta = np.atleast_2d(theta)
        w = theta.shape[0]
        p, z = np.ones((w, 1)), np.ones((w, 1))
        if self.has_lp:
            c1n, c0n = pendulum_coefficients(self.family.period_s, self.family.damping)
            p = np.column_stack([theta[:, 0] * c0n, theta[:, 1] * c1n, np.ones(w)])
        q = self.roots(theta)
        for k, it in enumerate(self.items):
            if it.complex_pair:      # (s - q)(s - q*) = s^2 - 2 Re q s + |q|^2
                f = np.column_stack([np.abs(q[:, k]) ** 2, -2.0 * q[:, k].real, np.ones(w)])
            else:
                f = np.column_stack([-q[:, k].real, np.ones(w)])
            if it.kind == "pole":
                p = _polymul(p, f)
            else:
                z = _polymul(z, f)
        return p, z

    def constant_factor(self, s):
        """``C(s)`` (F,): the nominal pendulum denominator (when the pair is
        fitted) and the free poles' nominal factors over the free zeros'."""
        s = np.asarray(s, complex)
        out = np.ones(s.shape, complex)
        if self.has_lp:
            fam = self.family
            out = out * fam.denominator(s, 2 * np.pi / fam.period_s, fam.damping)
        nominal = {"pole": [], "zero": []}
        for it in self.items:
            nominal[it.kind] += [it.nominal] + ([np.conj(it.nominal)] if it.complex_pair else [])
        return out * transfer(s, nominal["pole"], nominal["zero"])

    def physical(self, theta):
        """Samples in physical units: dict name -> (N,) (period_s, damping,
        gain) and ``hf`` (N, n_items) complex rad/s."""
        theta = np.atleast_2d(theta)
        out = {"gain": np.exp(theta[:, self.i_gain])}
        if self.has_lp:
            out["period_s"], out["damping"] = self.period_damping(theta)
        out["hf"] = self.roots(theta)
        return out

    def period_damping(self, theta):
        """(W,) period and damping of ``theta`` (W, ndim) with the pair fitted."""
        theta = np.atleast_2d(theta)
        return pendulum_to_physical(theta[:, 0], theta[:, 1], self.family.period_s,
                                    self.family.damping)


def _polymul(a, b):
    """Row-wise product of polynomials (W, m) and (W, n), lowest power first."""
    out = np.zeros((a.shape[0], a.shape[1] + b.shape[1] - 1))
    for j in range(b.shape[1]):
        out[:, j:j + a.shape[1]] += a * b[:, j:j + 1]
    return out


def poly_at_iw(coef, powers):
    """Real and imaginary part (W, F) of real polynomials ``coef`` (W, n),
    lowest power first, at ``s = i omega``: ``powers`` (n_max, F) holds
    ``i^k omega^k`` split as :func:`iw_powers` makes it."""
    even, odd = powers
    n = coef.shape[1]
    return coef[:, 0::2] @ even[:(n + 1) // 2], coef[:, 1::2] @ odd[:n // 2]


def iw_powers(omega, degree):
    """``(even, odd)``: ``Re (i omega)^2j`` and ``Im (i omega)^(2j+1)``, (j, F),
    for powers up to ``degree``: the real matrices that turn a real
    polynomial's coefficients into its value at ``i omega`` by products."""
    omega = np.asarray(omega, float)
    k = np.arange(degree + 1)[:, None]
    pw = omega[None] ** k * np.where(k % 4 < 2, 1.0, -1.0)
    return pw[0::2], pw[1::2]


def scale_start(run, spec, theta0, scale):
    """``theta0`` with its gain moved by the factor ``scale`` that the data
    show at the start; a reversed or absurd scale is refused (FitError naming
    the run), since it means wiring, polarity or the coil constant is wrong."""
    if not scale > 0:
        raise FitError(f"{run.source}: {run.ids[0]} responds to the coil with the opposite sign "
                       "to its nominal response: check the coil wiring or the output polarity")
    theta0 = np.array(theta0, float)
    theta0[spec.i_gain] += np.log(scale)
    lo, hi = spec.bounds()
    if not lo[spec.i_gain] < theta0[spec.i_gain] < hi[spec.i_gain]:
        raise FitError(f"{run.source}: the gain comes out {np.exp(theta0[spec.i_gain]):.4g}, "
                       f"more than {spec.priors.gain_factor:g}x from nominal "
                       f"{spec.family.gain:.4g}: check --coil-constant")
    return theta0


def _columns(roots, w):
    """(w, n) complex: the ``roots`` (each (w,)) as columns."""
    return np.stack(roots, axis=1) if roots else np.zeros((w, 0), complex)
