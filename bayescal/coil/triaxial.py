"""Symmetric triaxial geometry: the UVW matrices of known sensors, XYZ response
matrices ``M^T diag(k) M`` and their cross-talk, and rotation of recordings
between XYZ and UVW (conventions in :mod:`bayescal.coil.uvw`).
"""
from __future__ import annotations


import numpy as np

from ..core.orientation import STS2_UVW, TRILLIUM_UVW
from ..errors import InputError


ELEMENTS = ("U", "V", "W")
XYZ = ("X", "Y", "Z")
PARAMS = ("period_s", "damping", "gain")

SENSORS = {
    "sts2": (STS2_UVW, "Streckeisen STS-2 manual: X=(-2U+V+W)/sqrt6, Y=(V-W)/sqrt2, "
                       "Z=(U+V+W)/sqrt3 (bayescal.geometry.STS2_UVW)"),
    "trillium": (TRILLIUM_UVW, "Nanometrics Trillium manuals: X=(2U-V-W)/sqrt6, Y=(V-W)/sqrt2, "
                               "Z=(U+V+W)/sqrt3 (bayescal.geometry.TRILLIUM_UVW)"),
}

# --- geometry ---------------------------------------------------------------


def sensor_matrix(name):
    """Built-in UVW matrix and its source for ``"sts2"`` or ``"trillium"``."""
    try:
        m, src = SENSORS[name.lower()]
    except KeyError:
        raise InputError(f"unknown sensor {name!r}: choose one of {sorted(SENSORS)} "
                         "or give --matrix FILE") from None
    return np.array(m, float), src


def load_matrix(path):
    """Read a 3x3 UVW matrix (rows U, V, W over columns X, Y, Z) from a text
    file: whitespace- or comma-separated numbers, ``#`` comments. It must be
    orthonormal (to 1e-3), else :class:`InputError` naming the file."""
    try:
        with open(path) as fh:
            rows = [ln.split("#", 1)[0].replace(",", " ").split() for ln in fh]
        m = np.array([[float(x) for x in r] for r in rows if r], float)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read a 3x3 matrix ({exc})") from None
    if m.shape != (3, 3):
        raise InputError(f"{path}: expected 3 rows of 3 numbers (U, V, W over X, Y, Z), "
                         f"found shape {m.shape}")
    err = np.abs(m @ m.T - np.eye(3)).max()
    if err > 1e-3:
        raise InputError(f"{path}: the matrix is not orthonormal (|M M^T - I| = {err:.3g})")
    return m


def response_matrix(k, m):
    """XYZ response matrix ``M^T diag(k) M`` for element responses ``k`` of
    shape ``(..., 3, F)``; returns ``(..., 3, 3, F)`` (rows, columns X, Y, Z)."""
    return np.einsum("jl,jm,...jf->...lmf", m, m, k)


def seed_xyz_diagonal(h3, m):
    """The seed's Z-only algebra: ``g_l = sum_j M_jl^2 h^j_3 / M_j3`` from the
    Z outputs ``h3`` of the runs driving U, V, W (first axis: the element;
    any further axes, e.g. frequency, are carried along). Returns the XYZ
    diagonal responses, first axis X, Y, Z."""
    w = m * m / m[:, 2][:, None]
    return np.tensordot(w, np.asarray(h3), axes=(0, 0))


def cross_talk(t):
    """Largest relative cross-talk ``|T_lm| / sqrt(|T_ll T_mm|)`` (l != m) of
    response matrices ``t`` (``(..., 3, 3, F)``), over pairs and frequencies;
    returns ``(values (...,), pair index (...,) into (XY, XZ, YZ))``."""
    d = np.abs(np.einsum("...llf->...lf", t))
    pairs = [(0, 1), (0, 2), (1, 2)]
    rel = np.stack([np.abs(t[..., i, j, :]) / np.sqrt(d[..., i, :] * d[..., j, :])
                    for i, j in pairs], axis=-2)                     # (..., 3, F)
    per_pair = rel.max(axis=-1)
    return per_pair.max(axis=-1), per_pair.argmax(axis=-1)


# --- XYZ <-> UVW rotation of recorded data -----------------------------------

_AXIS_OF = {"N": "X", "1": "X", "E": "Y", "2": "Y", "Z": "Z", "U": "U", "V": "V", "W": "W"}


def output_axis(channel_code):
    """Sensor axis (X, Y, Z, U, V or W) of an output channel, from the last
    letter of its SEED code (N/1 -> X, E/2 -> Y, Z, U, V, W), else None."""
    return _AXIS_OF.get(channel_code[-1:].upper()) if len(channel_code) == 3 else None


def _rotate(stream, m, from_axes, to_axes, source):
    st = stream.copy()
    st.merge(method=0, fill_value=None)
    found = {}
    for tr in st:
        ax = output_axis(tr.stats.channel)
        if ax in from_axes:
            if ax in found:
                raise InputError(f"{source}: two channels for axis {ax}")
            found[ax] = tr
    missing = [a for a in from_axes if a not in found]
    if missing:
        raise InputError(f"{source}: no channel for axis {', '.join(missing)} "
                         f"(channels: {', '.join(tr.id for tr in st)})")
    trs = [found[a] for a in from_axes]
    if len({tr.stats.sampling_rate for tr in trs}) != 1:
        raise InputError(f"{source}: the three channels have different sampling rates")
    t0 = max(tr.stats.starttime for tr in trs)
    t1 = min(tr.stats.endtime for tr in trs)
    if t1 <= t0:
        raise InputError(f"{source}: the three channels do not overlap in time")
    for tr in trs:
        tr.trim(t0, t1, nearest_sample=True)
    n = min(tr.stats.npts for tr in trs)
    x = np.array([np.ma.filled(np.ma.masked_invalid(np.ma.asarray(tr.data[:n], float)), np.nan)
                  for tr in trs])
    y = m @ x
    out = st.__class__()
    for k, ax in enumerate(to_axes):
        tr = trs[0].copy()
        tr.data = np.ma.masked_invalid(y[k]) if np.isnan(y[k]).any() else y[k]
        tr.stats.channel = trs[0].stats.channel[:2] + ax
        out.append(tr)
    return out


def xyz_to_uvw(stream, m=STS2_UVW, source="stream"):
    """Rotate recorded X, Y, Z (channels ?H1/?HN, ?H2/?HE, ?HZ) to the
    element axes: ``u = M x``. Returns a Stream with channels ?HU, ?HV, ?HW
    (same units as the input; gaps stay masked)."""
    return _rotate(stream, np.asarray(m, float), XYZ, ELEMENTS, source)


def uvw_to_xyz(stream, m=STS2_UVW, source="stream"):
    """Inverse of :func:`xyz_to_uvw`: ``x = M^T u``; channels ?HN... are named
    ?H1, ?H2, ?HZ (X, Y, Z of the sensor frame)."""
    st = _rotate(stream, np.asarray(m, float).T, ELEMENTS, XYZ, source)
    for tr, code in zip(st, "12Z"):
        tr.stats.channel = tr.stats.channel[:2] + code
    return st
