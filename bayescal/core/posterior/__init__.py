"""Posterior samples and what users read from them.

* :mod:`.samples` the :class:`~bayescal.core.posterior.samples.Posterior`:
                  samples, per-channel summaries and intervals

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`
and :mod:`bayescal.core.checks`.
"""
