"""Self-noise of co-located sensors.

* :mod:`.sleeman`    three or more sensors (Sleeman), the Wishart-bootstrap
                     interval
* :mod:`.pair_noise` both sensors of a pair fit, from the fitted transfer

May import :mod:`bayescal.core.spectra`.
"""
