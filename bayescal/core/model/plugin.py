"""The plug-in noise model's own sampling error: a weight per band.

Both likelihoods hold a noise model estimated from the spectra themselves
(the SUT's residual covariance ``Sigma_b``, n_u x n_u, in the base model; the
band's whole cross-spectral matrix ``C_b``, (n_u + n_r) square, in the
errors-in-variables model). Each is a complex-Wishart-like estimate from the
band's bins and segments, worth ``nu_b`` independent samples: fewer than the
``K_b`` bins times segments it sums, because neighbouring bins of a Hann
window and overlapping segments are correlated
(:func:`bayescal.core.spectra.dof.band_dof`,
the equivalent degrees of freedom of a Welch estimate, from the window and
the segment layout alone). Treating the estimate as exact makes intervals
too narrow, by two effects of the same order:

* its inverse is biased: for ``S ~ CW(nu, Sigma) / nu`` of dimension ``p``,
  ``E[S^-1] = Sigma^-1 nu / (nu - p)``, so the plug-in precision is too high;
* the weights it gives the data are random, and a combination with random
  weights scatters more than its nominal variance (the second moment
  ``E[S^-1 M S^-1] ~ Sigma^-1 M Sigma^-1 nu^2 / ((nu - p)^2 - 1)``).

For a parameter estimated by generalised least squares with such a plug-in,
the standardised error's variance is ``nu^2 / ((nu - p)^2 - 1)`` when
several bands carry it; when one band carries it, less (1.46 against 1.63
at ``nu = 14``, ``p = 3``), so the weight below errs on the wide side there
(Monte Carlo in ``tests/test_plugin.py``). Each band's likelihood term is
therefore weighted by the inverse,

    w_b = ((nu_b - p)^2 - 1) / nu_b^2

(a tempered, or curvature-adjusted, likelihood: the band counts as ``w_b``
of itself), near 1 for long records (``nu_b`` in the hundreds) and smaller
where a band holds few segments (a 15-minute record at a 0.02 Hz lower
edge: ``nu_b`` about 25 in its lowest band, ``w_b`` about 0.77 with ``p =
3``). Derivation, checks and what it leaves: docs/validation/errors_in_variables.md,
"The plug-in's own sampling error: band weights".
"""
from __future__ import annotations

import numpy as np

#: Smallest weight a band gets (a band with fewer effective samples than the
#: noise model's dimension carries almost nothing).
MIN_WEIGHT = 0.05


def band_weights(nu, dim):
    """(B,) likelihood weight of each band (module docstring): ``((nu - p)^2
    - 1) / nu^2`` with ``nu`` the band's effective samples
    (:func:`bayescal.core.spectra.dof.band_dof`) and ``p = dim``, the dimension of the
    estimated covariance; at least :data:`MIN_WEIGHT`."""
    nu = np.asarray(nu, float)
    d = nu - float(dim)
    w = np.where(d > 1.0, (d * d - 1.0) / (nu * nu), 0.0)
    return np.clip(w, MIN_WEIGHT, 1.0)
