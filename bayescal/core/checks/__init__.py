"""Checks of a fit: does the model fit, can the data tell its parameters.

* :mod:`.adequacy`      posterior-predictive check of the per-band misfit
* :mod:`.separation`    how well a pair separates the reference's self-noise
                        from the SUT's gains
* :mod:`.record_length` is the record long enough for the band's lower edge
* :mod:`.repeatability` the scatter of medians over time windows against the
                        reported intervals

May import :mod:`bayescal.core.orientation`, :mod:`bayescal.core.response`,
:mod:`bayescal.core.spectra` and :mod:`bayescal.core.model`.
"""
