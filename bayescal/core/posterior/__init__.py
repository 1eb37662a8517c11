"""Posterior samples and what users read from them; no model, no file I/O.

* :mod:`.samples`     the :class:`~bayescal.core.posterior.samples.Posterior`:
                      samples, per-channel summaries and intervals
* :mod:`.modes`       the modes a fit reported: which intervals they lie outside
* :mod:`.convergence` the convergence warning and how a chain is told to a user

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`
and :mod:`bayescal.core.checks`.
"""
