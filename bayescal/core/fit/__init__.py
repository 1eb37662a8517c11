"""The whole fit, from spectra to posterior.

* :mod:`.run`           start, least squares, sampling, the posterior
* :mod:`.leastsq`       least squares: the one caller of scipy's, for every fit
* :mod:`.modes`         several optima of one posterior: searched and weighed
* :mod:`.unconstrained` a gain the data do not constrain: found and held
* :mod:`.assemble`      a fit's state put together from its model and samples
* :mod:`.rotation`      one reference channel, two SUT horizontals: their
                        common rotation

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`,
:mod:`bayescal.core.spectra`, :mod:`bayescal.core.model`,
:mod:`bayescal.core.checks`, :mod:`bayescal.core.sampling` and
:mod:`bayescal.core.posterior`: every group but
:mod:`bayescal.core.selfnoise`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "run": ["SPAN_TOLERANCE_DEG", "build_model", "fit_spectra",
            "least_squares_fit", "response_fit_refusal", "span_basis"],
    "leastsq": ["TIGHT", "jacobian", "refine", "solve"],
    "assemble": ["assemble_posterior", "plugin_meta"],
    "unconstrained": ["BOUND_FRACTION", "describe_late", "information", "late_flags",
                      "prior_bounds"],
})
