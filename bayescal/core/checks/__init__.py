"""Checks of a fit: does the model fit, can the data tell its parameters.

* :mod:`.adequacy`      posterior-predictive check of the per-band misfit
* :mod:`.gain_bounds`   the bounds a pair's spectra put on each SUT gain, and
                        whether the fit's gain is separable from the
                        reference's self-noise
* :mod:`.separation`    how well a pair separates the reference's self-noise
                        from the SUT's gains
* :mod:`.record_length` is the record long enough for the band's lower edge
* :mod:`.repeatability` the scatter of medians over time windows against the
                        reported intervals

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`,
:mod:`bayescal.core.spectra` and :mod:`bayescal.core.model`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "adequacy": ["ALPHA", "band_p_values", "describe", "from_diagnostics", "mismatch_flags"],
    "record_length": ["MIN_PERIODS", "record_length_entry"],
    "repeatability": ["reduced_chi_square", "sd_from_ci68"],
    "gain_bounds": ["identified_gains", "not_separable_note"],
    "separation": ["WIDE_RATIO", "gain_separation"],
})
