"""Instrument responses.

* :mod:`.family`   the parametric two-pole family (period, damping, gain) of a
                   velocity sensor, and the evaluation of ObsPy responses
* :mod:`.evalresp` a numpy evaluation of an ObsPy ``Response``
* :mod:`.paz`      a poles-and-zeros transfer function and its normalisation
* :mod:`.pendulum` the pendulum pair in the coordinates the data see, its
                   prior, and what the data fix
* :mod:`.reference_tolerance` the reference's metadata tolerance carried into
                   the SUT's response samples

Imports no other part of :mod:`bayescal.core`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "family": ["TwoPoleFamily", "evaluate_velocity_response", "gain_prior_factor",
               "paz_velocity_response", "pendulum_coefficients", "pendulum_denominator",
               "pendulum_poles", "response_family", "units_label"],
    "evalresp": ["velocity_response"],
    "paz": ["normalization_factor", "transfer"],
    "reference_tolerance": ["MIN_KISH", "SutPrior", "judged_sensitivity", "meta_entry",
                            "pendulum_pairs", "sampling_tolerances", "sut_priors",
                            "widen_responses"],
    "pendulum": ["DAMPING_TOLERANCE", "NAMES", "PERIOD_TOLERANCE", "damping_over_period",
                 "from_physical", "log_prior", "prior_residual", "prior_sensitivity",
                 "reweighted_sensitivity", "set_by_prior_entries", "to_physical"],
})
