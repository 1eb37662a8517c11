"""Model criticism: where the recordings and the model disagree, and why.

* :mod:`.effects`   the catalogue of physical effects the base model leaves out,
                    each a nested extension of the likelihood
* :mod:`.locate`    where the misfit is: per band and channel, with p-values
* :mod:`.search`    which effects to add: candidates, fits and BIC scores
* :mod:`.starts`    a candidate's least squares from its grid's best starting points
* :mod:`.per_block` the search's hand-over from the per-block likelihood (a clock
                    drift's) to the model with the reference's noise
* :mod:`.prior_choice`  whether to leave the sensor's stated prior for the wide
                    corner: the prior-data conflict test, then the evidence
* :mod:`.naming`    which kept effects are named: pruning, a timing offset's
                    consistency across the band, the posterior's exclusion of
                    each effect's absence
* :mod:`.diagnose`  the whole diagnosis: locate, name and model, show
* :mod:`.diagnosis` what the diagnosis found: its summary (diagnosis.json) and
                    its finding in plain words
* :mod:`.verdict`   the criticism of a fit that failed its model check
* :mod:`.moves`     how far modelling the effects moves the estimates, in words
* :mod:`.words`     the named effects in plain words: their labels and advice, and
                    the search's rounds
* :mod:`.advice`    advice that leads somewhere: options the run accepts, a
                    narrower band only where it helps
* :mod:`.wiring`    reversed or exchanged channels, from the fitted axes
* :mod:`.tilt`      tilt noise as a nested extension of a noise-spectrum model
* :mod:`.fitted_response`    each SUT channel's response as a fit sees it,
                    relative to its metadata, at any frequency
* :mod:`.reference_noise`  whether the reference's own self-noise is part of the
                    mismatch (a noise-model term, tested before any physics is named)

May import :mod:`bayescal.core`; never io, report, network or cli.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "tilt": ["ALPHA_RANGE", "base_fit", "nsr_data", "tilt_test"],
    "effects": ["ClockDrift"],
    "verdict": ["DEFAULT_BUDGET_S", "WORK_PER_SECOND", "check_orientation", "criticise",
                "criticism_budget", "failed", "lines"],
    "diagnose": ["posterior_of"],
    "diagnosis": ["EQUAL_SHAPE_CAVEAT", "REFERENCE_SHAPE_CAVEAT", "misfit_change",
                  "reference_shape_caveat"],
    "naming": ["weak_effects"],
    "fitted_response": ["relative_response", "model_response"],
    "locate": ["band_coherence", "block_timing"],
    "search": ["held_orientation_loglik", "with_effects"],
    "wiring": ["swaps_with_unfitted"],
})
