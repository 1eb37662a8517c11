"""The plug-in noise model's own sampling error: a weight per band.

Both likelihoods hold a noise model estimated from the spectra themselves
(the SUT's residual covariance ``Sigma_b``, n_u x n_u, in the base model; the
band's whole cross-spectral matrix ``C_b``, (n_u + n_r) square, in the
errors-in-variables model). Each is a complex-Wishart estimate from the
band's bins and segments, of about ``nu_b = K_b / c_b`` effective samples
(``K_b`` bins times segments, ``c_b`` the measured inflation: overlapping Hann
segments and neighbouring bins are not independent). Treating it as exact
makes intervals too narrow, by two effects of the same order:

* its inverse is biased: for ``S ~ CW(nu, Sigma) / nu`` of dimension ``p``,
  ``E[S^-1] = Sigma^-1 nu / (nu - p)``, so the plug-in precision is too high;
* the weights it gives the bands are random, and a weighted combination with
  random weights scatters more than its nominal variance (the second moment
  ``E[S^-1 M S^-1] ~ Sigma^-1 M Sigma^-1 nu^2 / ((nu - p)^2 - 1)``).

For a parameter carried by many bands the two combine to a variance
``nu^2 / ((nu - p)^2 - 1)`` times the nominal one (the ratio of the second
moment to the first, each band's share being small); a parameter carried by a
single band gets only the first, ``nu / (nu - p)``. Each band's likelihood
term is therefore weighted by

    w_b = ((nu_b - p)^2 - 1) / nu_b^2

(a tempered, or curvature-adjusted, likelihood: the band counts as ``w_b`` of
itself), which is near 1 for long records (``nu_b`` in the hundreds) and
matters where a band holds few segments (a 15-minute record at a 0.02 Hz lower
edge: ``nu_b`` about 20, ``w_b`` about 0.72 with ``p = 3``). Derivation,
checks and what it leaves: docs/errors_in_variables.md, "Short records".
"""
from __future__ import annotations

import numpy as np

#: Smallest weight a band gets (a band with fewer effective samples than the
#: noise model's dimension carries almost nothing).
MIN_WEIGHT = 0.05


def effective_samples(k, inflation):
    """(B,) effective complex-Wishart samples of each band's plug-in:
    ``K_b / c_b`` (``k`` bins times segments, ``inflation`` the band's
    ``c_b``)."""
    return np.asarray(k, float) / np.maximum(np.asarray(inflation, float), 1e-12)


def band_weights(k, inflation, dim):
    """(B,) likelihood weight of each band (module docstring): ``((nu - p)^2
    - 1) / nu^2`` with ``nu = K_b / c_b`` and ``p = dim``, the dimension of the
    estimated covariance; at least :data:`MIN_WEIGHT`."""
    nu = effective_samples(k, inflation)
    d = nu - float(dim)
    w = np.where(d > 1.0, (d * d - 1.0) / (nu * nu), 0.0)
    return np.clip(w, MIN_WEIGHT, 1.0)
