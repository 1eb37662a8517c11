"""Channel orientations: angles <-> unit vectors, SEED conventions, manifolds.

Frame and conventions (the one place they are written down)
-----------------------------------------------------------
Internally every direction is a unit vector in the local **North-East-Down**
frame ``(x=N, y=E, z=Down)``. In that frame the seed's eq. (1) row

    v = (cos a cos e, sin a cos e, sin e)

is exactly SEED/StationXML: ``a`` is the azimuth in degrees clockwise from
north and ``e`` is the dip in degrees *down* from horizontal, so an upward
vertical channel (positive output for upward motion) has dip -90 and
``v = (0, 0, -1)``. Ground motion vectors use the same frame (m/s).

A channel wired with reversed polarity is the same channel pointing the other
way: azimuth + 180, dip negated. There is no separate polarity parameter.

Sampling parametrisations (``Sphere``, ``Circle``, ``Fixed``) are local and
well conditioned everywhere, including at the vertical where the azimuth is
undefined: a direction is ``normalise(v0 + alpha*e1 + beta*e2)`` (gnomonic
coordinates in the tangent plane at ``v0``). A uniform prior on the sphere in
these coordinates has density ``(1 + alpha^2 + beta^2)^(-3/2)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Dip (degrees, absolute) beyond which a channel is reported as a tilt from
#: the vertical rather than by an (ill-defined) azimuth interval.
NEAR_VERTICAL_DIP_DEG = 80.0


def unit_vector(azimuth_deg, dip_deg):
    """Unit vector(s) in NED of a channel with SEED ``azimuth_deg``, ``dip_deg``.

    Broadcasts over its arguments; returns shape ``(..., 3)``.
    """
    a = np.radians(np.asarray(azimuth_deg, dtype=float))
    e = np.radians(np.asarray(dip_deg, dtype=float))
    return np.stack([np.cos(a) * np.cos(e), np.sin(a) * np.cos(e), np.sin(e)], axis=-1)


def azimuth_dip(v):
    """SEED azimuth in [0, 360) and dip in [-90, 90] (degrees) of vectors ``v``."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    az = np.degrees(np.arctan2(v[..., 1], v[..., 0])) % 360.0
    dip = np.degrees(np.arcsin(np.clip(v[..., 2], -1.0, 1.0)))
    return az, dip


def tilt_from_vertical(v):
    """Angle (degrees) between the channel axis and the vertical line, and the
    azimuth (degrees) toward which the axis' horizontal part points.

    Used to report near-vertical channels, whose azimuth is meaningless.
    """
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    tilt = np.degrees(np.arccos(np.clip(np.abs(v[..., 2]), 0.0, 1.0)))
    # direction of the horizontal part, for an axis pointing up (v_z < 0)
    sgn = np.where(v[..., 2] <= 0, 1.0, -1.0)
    toward = np.degrees(np.arctan2(sgn * v[..., 1], sgn * v[..., 0])) % 360.0
    return tilt, toward


def tilt_components(v):
    """Signed tilt (degrees) of a near-vertical axis toward north and toward
    east: the angles by which its upward direction leans. Unlike the tilt's
    size, both are well defined and nearly Gaussian when the tilt is small."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    up = np.where(v[..., 2:3] <= 0, v, -v)
    return np.degrees(np.arcsin(up[..., 0])), np.degrees(np.arcsin(up[..., 1]))


def unwrap_azimuths(samples_deg):
    """Shift azimuth samples by multiples of 360 so they sit contiguously around
    their circular mean, e.g. ``[359.8, 0.3]`` -> ``[-0.2, 0.3]``.

    Intervals computed from the result never jump across north. The centre is
    kept in [0, 360) when the mean lies there, so 3.0 stays 3.0.
    """
    s = np.asarray(samples_deg, dtype=float)
    r = np.radians(s)
    centre = np.degrees(np.arctan2(np.mean(np.sin(r)), np.mean(np.cos(r)))) % 360.0
    return centre + (s - centre + 180.0) % 360.0 - 180.0


def tangent_basis(v0):
    """Two unit vectors spanning the plane orthogonal to unit vector ``v0``."""
    v0 = np.asarray(v0, dtype=float)
    v0 = v0 / np.linalg.norm(v0)
    helper = np.array([0.0, 0.0, 1.0]) if abs(v0[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, v0)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(v0, e1)
    return e1, e2


@dataclass(frozen=True)
class Sphere:
    """A channel free to point anywhere: 2 parameters, gnomonic about ``v0``."""

    v0: np.ndarray
    n_params: int = 2

    def __post_init__(self):
        v0 = np.asarray(self.v0, float) / np.linalg.norm(self.v0)
        object.__setattr__(self, "v0", v0)
        object.__setattr__(self, "_frame", np.stack([v0, *tangent_basis(v0)]))

    def vectors(self, p):
        """``p`` shape (W, 2) -> unit vectors (W, 3)."""
        v = self._frame[0][None, :] + p @ self._frame[1:]
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    def params(self, v):
        """Inverse of :meth:`vectors` for a single vector on the v0 hemisphere."""
        v = np.asarray(v, float) / np.linalg.norm(v)
        c = self._frame @ v
        return c[1:] / c[0]

    def log_prior(self, p):
        """Uniform-on-the-sphere prior density in gnomonic coordinates."""
        return -1.5 * np.log1p(np.sum(p * p, axis=1))


@dataclass(frozen=True)
class Circle:
    """A channel constrained to the plane spanned by orthonormal ``e1``, ``e2``
    (for instance the horizontal plane of a reference without a vertical):
    one parameter, the angle from ``e1`` toward ``e2`` in radians. With
    ``e1`` = North and ``e2`` = East the angle is the azimuth."""

    e1: np.ndarray
    e2: np.ndarray
    n_params: int = 1

    def vectors(self, p):
        return np.cos(p[:, :1]) * self.e1[None, :] + np.sin(p[:, :1]) * self.e2[None, :]

    def params(self, v):
        return np.array([np.arctan2(v @ self.e2, v @ self.e1)])

    def log_prior(self, p):
        return np.zeros(p.shape[0])


@dataclass(frozen=True)
class Fixed:
    """A channel whose direction cannot be estimated from this reference: held
    at ``v0`` (only its response may be fitted)."""

    v0: np.ndarray
    n_params: int = 0

    def vectors(self, p):
        return np.broadcast_to(self.v0, (p.shape[0], 3)).copy()

    def params(self, v):
        return np.zeros(0)

    def log_prior(self, p):
        return np.zeros(p.shape[0])


# --- symmetric triaxial (UVW) sensors -------------------------------------

_S13, _S16, _S12, _S23 = np.sqrt(1 / 3), np.sqrt(1 / 6), np.sqrt(1 / 2), np.sqrt(2 / 3)

#: STS-2: rows U, V, W over columns X, Y, Z (Streckeisen STS-2 manual).
STS2_UVW = np.array([[-_S23, 0.0, _S13], [_S16, _S12, _S13], [_S16, -_S12, _S13]])

#: Trillium: the X column of the STS-2 matrix with its sign changed
#: (Nanometrics convention, see ../shared/GUIDE.md).
TRILLIUM_UVW = STS2_UVW * np.array([-1.0, 1.0, 1.0])[None, :]
