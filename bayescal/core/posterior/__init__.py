"""Posterior samples and what users read from them; no model, no file I/O.

* :mod:`.samples`     per-channel summaries and intervals of posterior samples
* :mod:`.state`       :class:`~bayescal.core.posterior.state.FitState`: a fit
                      in memory, and the frozen Result built from it
* :mod:`.modes`       the modes a fit reported: which intervals they lie outside
* :mod:`.convergence` the NOT CONVERGED line and how a chain is told to a user

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`,
:mod:`bayescal.core.checks` and :mod:`bayescal.result` (the Result it builds).

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "samples": ["channel_summaries", "describe_treatment", "interval_summary", "orthogonality",
                "sampled_azimuth_dip"],
    "state": ["FitState"],
    "modes": ["describe", "multimodal_line"],
    "convergence": ["describe_sampler", "not_converged_line"],
})
