"""Parametrisation of a channel's response for coil calibration: the
long-period pole pair (period, damping), the first-stage gain and the
high-frequency poles and zeros of the nominal response that the band reaches.

The response is the nominal one with the free parts replaced, so

    H(f; theta) / H_nom(f) = rho_lp(f; T, h, G) * prod_k phi_k(f) / |prod_k phi_k(f_n)|,

with ``rho_lp`` :meth:`bayescal.core.response.TwoPoleFamily.ratio` (gain and
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

from ..core.likelihood import Priors
from ..core.sampler import FitError
from ..core.response import TwoPoleFamily
from ..io.read import InputError

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

    ``theta`` is ``(ln T, h, ln G)`` for ``fit="lp"``, ``(ln G, hf...)`` for
    ``"hf"`` and ``(ln T, h, ln G, hf...)`` for ``"all"``; ``hf`` holds
    ``Re q / |q0|`` (and ``Im q / |q0|`` for a pair) per item.
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
    def names(self):
        out = ["log_period", "damping"] if self.has_lp else []
        out.append("log_gain")
        for k, it in enumerate(self.items):
            out += [f"{it.kind}{k}_re"] + ([f"{it.kind}{k}_im"] if it.complex_pair else [])
        return tuple(out)

    @property
    def ndim(self):
        return len(self.names)

    def nominal_theta(self):
        fam = self.family
        out = [np.log(fam.period_s), fam.damping] if self.has_lp else []
        out.append(np.log(fam.gain))
        for it in self.items:
            q = it.nominal / abs(it.nominal)
            out += [q.real] + ([q.imag] if it.complex_pair else [])
        return np.array(out)

    def bounds(self):
        fam, pr = self.family, self.priors
        lo, hi = [], []
        if self.has_lp:
            lo += [np.log(fam.period_s / pr.period_factor), pr.damping_range[0]]
            hi += [np.log(fam.period_s * pr.period_factor), pr.damping_range[1]]
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

    def _phi(self, s, q):
        """Product of the free factors at ``s`` (F,) for roots ``q`` (W, K): (W, F)."""
        out = np.ones((q.shape[0], s.size), complex)
        for k, it in enumerate(self.items):
            q0, qk = it.nominal, q[:, k][:, None]
            num = s - q0
            den = s[None] - qk
            if it.complex_pair:
                num = num * (s - np.conj(q0))
                den = den * (s[None] - np.conj(qk))
            f = num[None] / den
            out *= f if it.kind == "pole" else 1.0 / f
        return out

    def ratio(self, freqs, theta):
        """``H(f; theta) / H_nom(f)``, shape (W, F)."""
        theta = np.atleast_2d(theta)
        fam = self.family
        f = np.asarray(freqs, float)
        if self.has_lp:
            t, h = np.exp(theta[:, 0]), theta[:, 1]
        else:
            t, h = np.full(theta.shape[0], fam.period_s), np.full(theta.shape[0], fam.damping)
        r = fam.ratio(f, t, h, np.exp(theta[:, self.i_gain]))
        if self.items:
            q = self.roots(theta)
            r = r * self._phi(2j * np.pi * f, q) / np.abs(
                self._phi(np.array([2j * np.pi * fam.norm_freq]), q))
        return r

    def physical(self, theta):
        """Samples in physical units: dict name -> (N,) (period_s, damping,
        gain) and ``hf`` (N, n_items) complex rad/s."""
        theta = np.atleast_2d(theta)
        out = {"gain": np.exp(theta[:, self.i_gain])}
        if self.has_lp:
            out["period_s"] = np.exp(theta[:, 0])
            out["damping"] = theta[:, 1]
        out["hf"] = self.roots(theta)
        return out


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
