"""The plug-in noise model's own sampling error (:mod:`bayescal.core.plugin`).

1. The weight's formula against a Monte Carlo of its own model: a parameter
   combined over bands by generalised least squares whose noise covariances
   are complex-Wishart estimates of ``nu`` samples; the standardised error's
   variance is ``nu^2 / ((nu - p)^2 - 1)``, and 1 once each band is weighted.
2. Short records through the whole fit (``bayescal.calibrate``, MCMC): 15
   minutes at a 0.02 Hz lower edge, where the unweighted intervals came out
   10-35 % too narrow (docs/errors_in_variables.md, "Short records"), on
   seeds used nowhere else; the z sd is compared with the same fits without
   the weights.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from bayescal.core import plugin

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def _gls_z(rng, nu, p, bands, reps):
    """Standardised errors of a scalar estimated by GLS over ``bands`` bands,
    each with a plug-in covariance from ``nu`` complex samples."""
    z = np.empty(reps)
    for r in range(reps):
        num = den = 0.0
        for _ in range(bands):
            a = rng.normal(size=(p, p)) + 1j * rng.normal(size=(p, p))
            chol = np.linalg.cholesky(a @ a.conj().T / p + np.eye(p))
            m = rng.normal(size=p) + 1j * rng.normal(size=p)
            x = chol @ (rng.normal(size=(p, nu)) + 1j * rng.normal(size=(p, nu))) / np.sqrt(2)
            prec = np.linalg.inv(x @ x.conj().T / nu)
            e = chol @ (rng.normal(size=p) + 1j * rng.normal(size=p)) / np.sqrt(2)
            num += 2 * (m.conj() @ prec @ e).real
            den += 2 * (m.conj() @ prec @ m).real
        z[r] = num / np.sqrt(den)
    return z


@pytest.mark.parametrize("nu, p", [(20, 3), (24, 6)])
def test_weight_matches_the_plug_in_variance(nu, p):
    rng = np.random.default_rng(7)
    z = _gls_z(rng, nu, p, bands=4, reps=2500)
    w = plugin.band_weights([nu], [1.0], p)[0]
    assert w == pytest.approx(((nu - p) ** 2 - 1) / nu ** 2)
    # the plug-in's intervals are too narrow (var z 1.39 and 2.06 here) ...
    assert z.var() > 1.25
    # ... and weighting each band by w restores them (MC sd of var ~ 3-4 %)
    assert z.var() * w == pytest.approx(1.0, abs=0.12)


def test_weight_limits():
    w = plugin.band_weights([1000.0, 40.0, 8.0, 2.0], [2.0, 2.0, 2.0, 2.0], 3)
    assert w[0] == pytest.approx((497.0 ** 2 - 1) / 500.0 ** 2)   # long records: about 1
    assert w[0] > 0.98 and w[1] < w[0]
    assert w[2] == plugin.MIN_WEIGHT and w[3] == plugin.MIN_WEIGHT


def _short_fits(seeds, mode, weighted):
    import eiv_coverage as ec
    orig = plugin.band_weights
    if not weighted:
        plugin.band_weights = lambda k, c, dim: None
    try:
        return [ec.run_pair(s, 1.0 if mode == "estimate" else 0.0, 0.99, "gain", mode,
                            duration=900.0) for s in seeds]
    finally:
        plugin.band_weights = orig


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["quiet", "estimate"])
def test_short_record_intervals(mode):
    """900-s pairs (614 s used, 12 periods of the 0.02 Hz edge), gains 3 %
    off their metadata and fitted; quiet: noise-free reference; estimate:
    the reference as noisy as the SUT. Angles and gains pooled."""
    seeds = range(3000, 3020)

    def pooled(rows):
        c = [c for r in rows for name, c in r["checks"].items()
             if name.split(":")[1] in ("azimuth", "dip", "gain")]
        return (np.std([v["z"] for v in c], ddof=1), int(sum(v["in90"] for v in c)), len(c))

    sd_w, in_w, n = pooled(_short_fits(seeds, mode, True))
    sd_u, _, _ = pooled(_short_fits(seeds, mode, False))
    from bayescal.simulate.coverage import binomial_band
    lo, hi = binomial_band(n, 0.9)
    assert lo <= in_w <= hi, (in_w, n, (lo, hi))
    assert sd_w < 1.12, sd_w
    assert sd_w < sd_u - 0.05, (sd_w, sd_u)
