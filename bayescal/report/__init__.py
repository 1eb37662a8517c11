"""PDF/PNG reports, one module per kind, figures beside them.

* :mod:`.layout`     what every page shares: context, style, tables, headers, and
                     the loop writing a report's pages into its PDF and PNGs
* :mod:`.axes`       axis helpers: log-frequency ticks, the PSD's unit
* :mod:`.tables`     rows of the fit report (intervals, nominal, deviations)
* :mod:`.fit`        the fit report from a result folder
* :mod:`.fit_pages`  its pages
* :mod:`.corner_pages` its corner plots (angles; response parameters per channel)
* :mod:`.pair_noise` its self-noise page: both sensors of the pair
* :mod:`.diagnosis`  the diagnosis page
* :mod:`.uvw`        the UVW calibration report
* :mod:`.cal`        the coil calibration report of one channel (random, step)
* :mod:`.cal_time`   its time-series pages (step, sine)
* :mod:`.batch`      the network tables and report
* :mod:`.noise`      the self-noise pages (against the NLNM and NHNM)

May import core, io, criticism and coil; never network or cli.
"""
from .fit import load_result, write_report

__all__ = ["load_result", "write_report"]
