"""The likelihood: a new likelihood term or noise model goes here.

* :mod:`.likelihood`   the Frobenius residual, its noise model, vectorised
                       log-probability
* :mod:`.eiv`          the likelihood when both sensors are noisy (errors in
                       variables)
* :mod:`.refnoise`     the reference's self-noise statistic and its covariance
* :mod:`.noisescale`   the SUT's self-noise held fixed in its counts
* :mod:`.plugin`       band weights for the plug-in noise model's sampling error
* :mod:`.misfit_scale` the per-band noise scale, marginalised
* :mod:`.effect`       the hook by which a physical effect extends the likelihood
* :mod:`.jacobian`     forward-difference Jacobian of the whitened residual

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`
and :mod:`bayescal.core.spectra`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
from ...lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    ".likelihood": ["ChannelBlock", "INFLATION_SHRINK", "MIN_TIME_BLOCKS", "Model"],
    ".effect": ["Effect"],
    ".eiv": ["EIVModel", "EIVNoise"],
    ".misfit_scale": ["MISFIT_SHAPE", "band_loglik", "band_scale"],
    ".refnoise": ["band_sums_of_psd", "recommended_mode", "treatment_meta"],
    ".jacobian": ["forward_jacobian", "least_squares_objective"],
})
