"""Synthetic recordings with known truth.

* :mod:`.pair`      a co-located pair (with concealed effects on request)
* :mod:`.coil`      coil calibration runs of a triaxial sensor
* :mod:`.cal`       a random, step or sine coil calibration run of one channel
* :mod:`.network`   an SDS archive of pairs over stations and days
* :mod:`.selfnoise` three co-located sensors with known self-noise
* :mod:`.coverage`  the uncertainty check: simulate, fit, count the truths inside
* :mod:`.harness`   seeded draws the validation studies and the tests share

The generators import only :mod:`bayescal.core` (:mod:`.selfnoise` builds
its StationXML with :func:`bayescal.io.read.paz_inventory`); :mod:`.coverage` also runs
:mod:`bayescal.pair` on what it simulates, and :mod:`.harness` computes
a pair's cross-spectra with :mod:`bayescal.io.align` (neither is imported here).
"""
from .coil import simulate_calibration
from .network import write_network
from .pair import simulate_pair

__all__ = ["simulate_calibration", "simulate_pair", "write_network"]
