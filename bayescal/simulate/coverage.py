"""Uncertainty checks on simulated noise: draw pairs with known truth, fit
them, and count how often each truth falls inside its credible interval.

Used by ``validation/studies/coverage_study.py`` (the full study) and the test suite
(a smaller one); users can run the same check for their own configuration
(record length, band, sampling rate) before trusting intervals.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import binom

from ..core.orientation import tilt_components, unit_vector, unwrap_azimuths
from ..core.posterior import sampled_azimuth_dip
from ..pair.workflow import calibrate
from .pair import simulate_pair

NOMINAL = (30.0, 0.707, 750.0)


def draw_case(seed):
    """Random truth for one simulated pair."""
    rng = np.random.default_rng(10_000 + seed)
    az = rng.uniform(0, 360)
    azs = (az, az + 90 + rng.normal(0, 1), rng.uniform(0, 360))
    dips = (rng.normal(0, 1), rng.normal(0, 1), -90 + abs(rng.normal(0, 1)))
    resp = tuple(tuple(np.array(NOMINAL) * (1 + rng.normal(0, [0.05, 0.05, 0.02])))
                 for _ in range(3))
    coherence = 1 - 10 ** rng.uniform(-3, -1)
    return azs, dips, resp, coherence


def run_case(seed, duration, fs, band, fit_response, **calibrate_kw):
    """One seeded case fitted as ``bayescal fit`` does (``calibrate_kw`` to
    :func:`bayescal.pair.workflow.calibrate`, e.g. ``ref_noise``); returns the
    result and the truth."""
    azs, dips, resp, coh = draw_case(seed)
    if fit_response == "none":            # response held at nominal: truth must be nominal
        resp = (NOMINAL,) * 3
    elif fit_response == "gain":          # only gains free: period and damping nominal
        resp = tuple((NOMINAL[0], NOMINAL[1], r[2]) for r in resp)
    sim = simulate_pair(duration=duration, fs=fs, seed=seed, coherence=coh, sut_azimuth=azs,
                        sut_dip=dips, sut_response=resp, nominal_response=NOMINAL)
    post = calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                     sut_xml=sim.sut_inventory, band=band,
                     fit_response=fit_response, seed=seed, progress=False, **calibrate_kw)
    return post, azs, dips, resp, coh


def coverage_checks(post, azs, dips, resp, level=90.0):
    """Dict name -> (inside interval?, standardised error) for every truth."""
    lo_q, hi_q = (100 - level) / 2, 100 - (100 - level) / 2
    out = {}
    az, dip = sampled_azimuth_dip(post.vectors)
    for k, cid in enumerate(post.channel_ids):
        short = cid.split(".")[-1]
        if abs(dips[k]) > 80:
            # the signed tilt components are checked, not the tilt's size: an
            # interval on a magnitude near zero cannot cover (Rice bias)
            tn, te = tilt_components(post.vectors[:, k])
            tn0, te0 = tilt_components(unit_vector(azs[k], dips[k])[None])
            pairs = {f"{short}:tilt_north": (tn, tn0[0]), f"{short}:tilt_east": (te, te0[0])}
        else:
            a = unwrap_azimuths(np.r_[az[:, k], azs[k]])
            pairs = {f"{short}:azimuth": (a[:-1], a[-1]), f"{short}:dip": (dip[:, k], dips[k])}
        if cid in post.response:
            r = post.response[cid]
            names = ("period", "damping", "gain") if post.meta.free_response == "all" else ()
            if post.meta.free_response == "gain":
                names = ("gain",)
            for name in names:
                j = ("period", "damping", "gain").index(name)
                pairs[f"{short}:{name}"] = (r[:, j], resp[k][j])
        for name, (s, truth) in pairs.items():
            lo, hi = np.percentile(s, [lo_q, hi_q])
            out[name] = (bool(lo <= truth <= hi), float((np.median(s) - truth) / np.std(s)))
    return out


def binomial_band(n, p=0.9, alpha=0.01):
    """Central (1 - alpha) band for the count of successes."""
    return int(binom.ppf(alpha / 2, n, p)), int(binom.ppf(1 - alpha / 2, n, p))


def summarise(rows):
    """Per parameter kind and overall: count inside, band, verdict."""
    kinds = {}
    for r in rows:
        for name, (inside, z) in r["checks"].items():
            kind = name.split(":")[1]
            kinds.setdefault(kind, []).append((inside, z))
    out = {}
    allv = [v for vals in kinds.values() for v in vals]
    for kind, vals in list(kinds.items()) + [("all", allv)]:
        n = len(vals)
        k = int(sum(v[0] for v in vals))
        lo, hi = binomial_band(n)
        z = np.array([v[1] for v in vals])
        out[kind] = {"n": n, "inside": k, "rate": k / n, "band99": [lo, hi],
                     "consistent": bool(lo <= k <= hi), "z_mean": float(z.mean()),
                     "z_sd": float(z.std())}
    return out
