"""A second family of ground-motion spectra for :func:`.pair.simulate_pair`.

The default field (:func:`.pair.ground_spectrum` carried by a few plane
waves) gives every wave one spectral shape, so each axis's ground power has
the same shape over frequency: only its level differs between the
horizontals and the vertical. Real ground motion is not like that. This
family, :class:`SteepMicroseism`, draws:

* a velocity spectrum falling steeply below a corner (0.05 Hz by default;
  power as ``f^steepness`` below it), as the ground's motion falls below
  the primary microseism at a quiet site;
* microseism peaks (primary, secondary and a short-period one), each
  arriving from several directions, every arrival a Rayleigh wave (vertical
  90 degrees from radial, with its own ellipticity) or a Love wave
  (transverse, horizontal only), with its own weight, so the horizontals'
  and the vertical's spectra differ in shape, peak by peak;
* a three-dimensional isotropic background (equal, incoherent power on the
  three axes) under the peaks.

Each component is a Gaussian field with its own spectrum; the expected 3x3
cross-spectral matrix is their sum. The directions, kinds and weights come
from ``wave_seed``'s own generator when given (the same field at any record
length), else from the record's generator before its per-bin draws.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Microseism peaks of the family: (centre Hz, width in natural-log
#: frequency, relative peak power).
PEAKS = ((0.065, 0.25, 0.3), (0.16, 0.3, 1.0), (0.35, 0.3, 0.15))


@dataclass(frozen=True)
class SteepMicroseism:
    """The second ground family (see the module docstring).

    Parameters
    ----------
    corner_hz : the ground's velocity power falls as ``(f / corner_hz) ^
        steepness`` below this.
    steepness : exponent of that fall (power).
    directions : arrivals per microseism peak.
    love_share : probability that an arrival is a Love wave.
    background : the isotropic background's power relative to the
        secondary peak's, per axis.
    peaks : (centre Hz, log width, relative power) of each peak.
    """

    corner_hz: float = 0.05
    steepness: float = 6.0
    directions: int = 3
    love_share: float = 0.4
    background: float = 0.02
    peaks: tuple = PEAKS
    name: str = "steep-microseism"

    def fall(self, f):
        """The steep fall below the corner (1 above it; 0 at f = 0)."""
        f = np.asarray(f, float)
        with np.errstate(divide="ignore"):
            x = np.where(f > 0, self.corner_hz / np.where(f > 0, f, 1.0), np.inf)
        return 1.0 / (1.0 + x ** self.steepness)

    def peak_psd(self, f, peak):
        """Velocity power shape of one peak (before the fall)."""
        fc, width, level = peak
        f = np.asarray(f, float)
        lf = np.log(np.where(f > 0, f, 1.0))
        return np.where(f > 0, level * np.exp(-((lf - np.log(fc)) / width) ** 2), 0.0)

    def arrivals(self, prng):
        """[(peak index, azimuth rad, weight, polarisation (3,) complex, kind)]
        of every arrival, drawn from ``prng`` (NED axes, down positive)."""
        out = []
        for k in range(len(self.peaks)):
            for _ in range(self.directions):
                phi = prng.uniform(0, 2 * np.pi)
                weight = prng.uniform(0.3, 1.0)
                radial = np.array([np.cos(phi), np.sin(phi), 0.0])
                if prng.uniform() < self.love_share:
                    pol, kind = np.array([-np.sin(phi), np.cos(phi), 0.0]).astype(complex), "love"
                else:
                    ell = prng.uniform(0.6, 1.5)        # vertical over radial amplitude
                    pol, kind = radial + np.array([0, 0, -1.0]) * ell * 1j, "rayleigh"
                out.append((k, phi, weight, pol, kind))
        return out

    def draw(self, rng, freqs, wave_seed=None):
        """(3, F) complex ground-velocity spectrum (NED) and its expected
        cross-spectral matrix (F, 3, 3), as :func:`.pair.simulate_pair`
        uses them."""
        prng = rng if wave_seed is None else np.random.default_rng([wave_seed, 98])
        fall = self.fall(freqs)
        g = np.zeros((3, freqs.size), complex)
        expected = np.zeros((freqs.size, 3, 3), complex)
        for k, _, weight, pol, _ in self.arrivals(prng):
            psd = weight ** 2 * self.peak_psd(freqs, self.peaks[k]) * fall
            c = np.sqrt(psd / 2.0) * (rng.standard_normal(freqs.size)
                                      + 1j * rng.standard_normal(freqs.size))
            g += pol[:, None] * c[None, :]
            expected += psd[:, None, None] * np.outer(pol, pol.conj())[None]
        bg = self.background * fall * np.where(freqs > 0, 1.0, 0.0)
        for axis in range(3):
            g[axis] += np.sqrt(bg / 2.0) * (rng.standard_normal(freqs.size)
                                            + 1j * rng.standard_normal(freqs.size))
            expected[:, axis, axis] += bg
        return g, expected


#: The ground families :func:`.pair.simulate_pair` knows by name.
FAMILIES = {"default": None, "steep-microseism": SteepMicroseism()}


def ground_family(ground):
    """The ground family ``ground`` names (None or "default": the default
    plane-wave field), or ``ground`` itself when it is a family object (one
    with a ``draw(rng, freqs, wave_seed)`` method)."""
    if ground is None or hasattr(ground, "draw"):
        return ground
    try:
        return FAMILIES[ground]
    except KeyError:
        raise ValueError(f"unknown ground family {ground!r}; one of {sorted(FAMILIES)}") from None
