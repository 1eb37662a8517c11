"""Posterior samples and what users read from them; no model, no file I/O.

* :mod:`.samples`     per-channel summaries and intervals of posterior samples
* :mod:`.state`       :class:`~bayescal.core.posterior.state.FitState`: a fit
                      in memory, and the frozen Result built from it
* :mod:`.modes`       the modes a fit reported: which intervals they lie outside
* :mod:`.convergence` the convergence warning and how a chain is told to a user

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`
and :mod:`bayescal.core.checks`.
"""
