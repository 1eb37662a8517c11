"""Every interval a user reads, recomputed from what it says it is computed
from, written apart from bayescal's summary code (no bayescal import here).

A label ``ciNN`` names the equal-tailed NN % interval: the (100 - NN) / 2 and
100 - (100 - NN) / 2 percentiles of the posterior samples (numpy's default
linear interpolation). The percentiles are taken from the label's number
itself, so an interval computed at another level than its label says, or
copied from another label, does not match.

A near-vertical channel's tilt (and the dip that follows it) is stated
differently (result.json's ``interval`` note): the range of tilts over the
elliptical credible region of the lean north/east components, the region
holding the ``NN`` % of the samples nearest their mean in Mahalanobis
distance; :func:`tilt_region` recomputes it from the axis samples.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

#: The interval labels of result.json, cal.json and uvw.json.
LABELS = ("ci68", "ci90", "ci95")
#: Float bound for a value recomputed from the same samples: the percentiles
#: are of identical numbers except for the angles, which are recomputed from
#: the axis vectors with other float operations (errors of order 1e-13 deg).
FLOAT = 1e-9


def level(label):
    """The credible level (percent) a label such as ``ci95`` names."""
    return float(re.fullmatch(r"ci(\d+)(_db)?", label).group(1))


def tails(label):
    """Lower and upper percentile of the equal-tailed interval ``label``."""
    p = level(label)
    return (100.0 - p) / 2.0, 100.0 - (100.0 - p) / 2.0


def equal_tailed(x, labels=LABELS):
    """Median, sd (population) and the labelled equal-tailed intervals of ``x``."""
    x = np.asarray(x, float)
    out = {"median": float(np.percentile(x, 50.0)), "sd": float(np.std(x))}
    for lab in labels:
        out[lab] = [float(v) for v in np.percentile(x, tails(lab))]
    return out


def assert_entry(entry, x, where, rtol=FLOAT, atol=FLOAT, labels=LABELS):
    """A summary entry's median, sd and intervals against samples ``x``."""
    want = equal_tailed(x, labels)
    for key, value in want.items():
        np.testing.assert_allclose(entry[key], value, rtol=rtol, atol=atol,
                                   err_msg=f"{where} {key}")


# --- angles from the sampled axes ------------------------------------------------------
def axis_angles(vectors):
    """SEED azimuth (degrees clockwise from north) and dip (degrees down)
    of NED axis vectors (..., 3)."""
    v = np.asarray(vectors, float)
    v = v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return np.degrees(np.arctan2(v[..., 1], v[..., 0])), np.degrees(np.arcsin(v[..., 2]))


def around_mean_direction(az):
    """Azimuth samples moved by whole turns to lie within half a turn of
    their mean direction (the convention result.json states: an interval
    crossing north stays contiguous)."""
    a = np.radians(az)
    centre = np.degrees(np.arctan2(np.sin(a).mean(), np.cos(a).mean())) % 360.0
    return centre + np.remainder(np.asarray(az) - centre + 180.0, 360.0) - 180.0


def lean(vectors):
    """Lean toward north and east (degrees) of a near-vertical axis: the
    angles by which its upward-pointing direction leans."""
    v = np.asarray(vectors, float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    up = v * np.where(v[:, 2] > 0, -1.0, 1.0)[:, None]
    return np.degrees(np.arcsin(up[:, 0])), np.degrees(np.arcsin(up[:, 1]))


#: Points at which bayescal walks a tilt region's boundary, and this module.
CODE_WALK, WALK = 4096, 20000


def tilt_region(vectors, label, n=WALK):
    """(lo, hi, holds_vertical, semi-major axis) of the tilt over the
    ``label`` elliptical credible region of the lean samples: lo 0 when the
    region holds lean (0, 0). The region's boundary is walked along its
    principal axes at ``n`` points."""
    x = np.column_stack(lean(vectors))
    m = x.mean(axis=0)
    d = x - m
    S = d.T @ d / (len(x) - 1)
    w, U = np.linalg.eigh(S)
    d2 = np.sum((d @ U) ** 2 / w, axis=1)
    q = np.percentile(d2, level(label))
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    edge = m + (np.sqrt(q * w) * np.column_stack([np.cos(t), np.sin(t)])) @ U.T
    s = np.sin(np.radians(edge))
    tilt = np.degrees(np.arcsin(np.minimum(np.hypot(s[:, 0], s[:, 1]), 1.0)))
    mz = m @ U
    holds = bool(np.sum(mz ** 2 / w) <= q)
    return (0.0 if holds else float(tilt.min())), float(tilt.max()), holds, \
        float(np.sqrt(q * w.max()))


# --- a fit's result folder --------------------------------------------------------------
def read_fit(folder):
    """(result.json, samples.npz arrays, its channel ids) of a fit folder."""
    folder = Path(folder)
    res = json.loads((folder / "result.json").read_text())
    with np.load(folder / "samples.npz") as z:
        arrays = {k: z[k] for k in z.files}
    ids = json.loads(str(arrays["extra"]))["channel_ids"]
    return res, arrays, ids


def fit_samples(folder):
    """Every quantity with intervals in a fit's result.json, as
    ``{(channel or pair, path): samples}`` from samples.npz; ``path`` the
    keys leading to the entry, e.g. ``("response", "gain")``. A
    near-vertical channel's ``tilt_deg`` and ``dip_deg`` map to
    ``("region", axis samples, tilt or dip samples)`` (the intervals: see
    :func:`tilt_region`; the median and sd: of the tilt or dip samples)."""
    res, z, ids = read_fit(folder)
    out = {}
    az, dip = axis_angles(z["vectors"])
    horizontals = []
    for k, cid in enumerate(ids):
        ch = res["channels"][cid]
        if "tilt_deg" in ch:
            v = z["vectors"][:, k]
            tilt = np.degrees(np.arccos(np.minimum(np.abs(v[:, 2]) / np.linalg.norm(v, axis=1),
                                                   1.0)))
            out[cid, ("tilt_deg",)] = ("region", v, tilt)
            out[cid, ("dip_deg",)] = ("region", v, dip[:, k])
            north, east = lean(z["vectors"][:, k])
            out[cid, ("tilt_north_deg",)] = north
            out[cid, ("tilt_east_deg",)] = east
        else:
            if not ch["azimuth_deg"].get("fixed"):
                out[cid, ("azimuth_deg",)] = around_mean_direction(az[:, k])
            if not ch["dip_deg"].get("fixed"):
                out[cid, ("dip_deg",)] = dip[:, k]
            if ch["kind"] != "fixed" and abs(np.median(dip[:, k])) < 45.0:
                horizontals.append(k)
        r = z.get(f"response::{cid}")
        resp = ch.get("response", {})
        if r is None:
            continue
        columns = {"period_s": r[:, 0], "damping": r[:, 1], "gain": r[:, 2],
                   "damping_over_period": r[:, 1] / r[:, 0]}
        nominal = (ch.get("nominal") or {}).get("gain")
        if nominal:
            columns["relative_gain"] = r[:, 2] / nominal
        for name, x in columns.items():
            if name in resp and not resp[name].get("fixed"):
                out[cid, ("response", name)] = x
    if len(horizontals) == 2 and not res["meta"].get("assumption"):
        i, j = horizontals
        v = z["vectors"]
        cos = np.sum(v[:, i] * v[:, j], axis=1) / (np.linalg.norm(v[:, i], axis=1)
                                                     * np.linalg.norm(v[:, j], axis=1))
        out[f"{ids[i]}/{ids[j]}", ("orthogonality",)] = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    return res, out


def entry_of(res, key, path):
    if path == ("orthogonality",):
        return res["orthogonality_deg"][key]
    e = res["channels"][key]
    for p in path:
        e = e[p]
    return e


def region_interval(vectors, label, dip=False):
    """The tilt (or, ``dip``, the SEED dip) interval of the ``label`` region,
    and the bound on its difference from bayescal's (:func:`region_tolerance`)."""
    lo, hi, _, a = tilt_region(vectors, label)
    up = np.median(np.asarray(vectors)[:, 2]) <= 0
    ci = [lo, hi] if not dip else [-90.0 + lo, -90.0 + hi] if up else [90.0 - hi, 90.0 - lo]
    return ci, region_tolerance(a)


def region_tolerance(semi_major):
    """Bound on the difference of two walks of a tilt region's boundary
    (degrees): half a step of each walk, pi a / n for semi-major axis ``a``
    and n points (bayescal's 4096, this module's 20000). A walk's extreme
    is off by at most half a step along the boundary: where the region
    passes near the vertical the tilt has a corner there (a maximum, smooth,
    is off far less)."""
    return np.pi * semi_major * (1.0 / CODE_WALK + 1.0 / WALK) + FLOAT


def assert_fit_folder(folder):
    """Every interval (and median, sd) of a fit's result.json against its
    samples.npz; returns the number of entries checked (a tilt region's
    range to :func:`region_tolerance`)."""
    res, samples = fit_samples(folder)
    for (key, path), x in samples.items():
        entry, where = entry_of(res, key, path), f"{key} {'.'.join(path)}"
        if isinstance(x, tuple):            # a near-vertical channel's tilt or dip
            vectors = x[1]
            assert_entry(entry, x[2], where, labels=())
            for lab in LABELS:
                want, tol = region_interval(vectors, lab, dip=path == ("dip_deg",))
                np.testing.assert_allclose(entry[lab], want, rtol=0, atol=tol,
                                           err_msg=f"{where} {lab}")
            if path == ("tilt_deg",):
                assert entry["holds_zero"] == tilt_region(vectors, "ci95")[2], where
        else:
            assert_entry(entry, x, where)
    return len(samples)
