"""The likelihood: a new likelihood term or noise model goes here.

* :mod:`.likelihood`   the Frobenius residual, its noise model, vectorised
                       log-probability
* :mod:`.channel`      how one SUT channel enters the model (parameters, bounds)
* :mod:`.protocol`     the interface every model (pair, coil, UVW) implements
* :mod:`.eiv`          the likelihood when both sensors are noisy (errors in
                       variables)
* :mod:`.refnoise`     the reference's self-noise statistic and its covariance
* :mod:`.noise_range`  the reference's noise profiled within the range the
                       spectra admit
* :mod:`.noisescale`   the SUT's self-noise held fixed in its counts
* :mod:`.nodes`        the frequency nodes of the response ratios and their
                       interpolation to the bins
* :mod:`.inflation`    the noise-inflation factor, shrunk toward its pooled value
* :mod:`.plugin`       band weights for the plug-in noise model's sampling error
* :mod:`.misfit_scale` the per-band noise scale, marginalised
* :mod:`.channel_scale` the same per SUT channel: each channel's share of a
                       band's whitened residual energy
* :mod:`.effect`       the hook by which a physical effect extends the likelihood
* :mod:`.jacobian`     forward-difference Jacobian of the whitened residual

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`
and :mod:`bayescal.core.spectra`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "likelihood": ["MIN_TIME_BLOCKS", "Model"],
    "channel": ["ChannelBlock"],
    "inflation": ["INFLATION_SHRINK", "lag_one_scatter", "overlapping_segments",
                  "shrunk_inflation"],
    "protocol": ["PosteriorModel"],
    "effect": ["CLOCK_EFFECTS", "Effect", "is_clock"],
    "eiv": ["EIVModel", "EIVNoise"],
    "misfit_scale": ["MISFIT_SHAPE", "band_loglik", "band_scale"],
    "refnoise": ["as_real", "band_sums_of_psd", "recommended_mode", "treatment_meta"],
    "jacobian": ["forward_jacobian", "least_squares_objective"],
})
