"""The whole fit, from spectra to posterior.

* :mod:`.run`           start, least squares, sampling, the posterior
* :mod:`.leastsq`       least squares: the one caller of scipy's, for every fit
* :mod:`.modes`         several optima of one posterior: searched and weighed
* :mod:`.unconstrained` a gain the data do not constrain: found and held
* :mod:`.assemble`      a fit's Posterior put together from its model and samples
* :mod:`.rotation`      one reference channel, two SUT horizontals: their
                        common rotation

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`,
:mod:`bayescal.core.spectra`, :mod:`bayescal.core.model`,
:mod:`bayescal.core.checks`, :mod:`bayescal.core.sampling` and
:mod:`bayescal.core.posterior`: every group but
:mod:`bayescal.core.selfnoise`.
"""
