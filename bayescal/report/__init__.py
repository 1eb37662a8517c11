"""PDF/PNG reports, one module per kind, figures beside them.

* :mod:`.layout`     what every page shares: context, style, tables, headers, and
                     the loop writing a report's pages into its PDF and PNGs
* :mod:`.axes`       axis helpers: log-frequency ticks, the PSD's unit
* :mod:`.in_view`    ticks made only where they are drawn (in the axis's view)
* :mod:`.placed_table` the summary tables, their cells placed once
* :mod:`.collection` the cyclic garbage collector paused while a report is drawn
* :mod:`.tables`     rows of the fit report (intervals, nominal, deviations)
* :mod:`.fit`        the fit report from a result folder
* :mod:`.fit_pages`  its pages
* :mod:`.corner_pages` its corner plots (angles; response parameters per channel)
* :mod:`.pair_noise` its self-noise page: both sensors of the pair
* :mod:`.response_curve` its page of the SUT's response relative to the
                     reference's metadata (result.json's ``response_curve``)
* :mod:`.diagnosis`  the diagnosis page
* :mod:`.uvw`        the UVW calibration report
* :mod:`.cal`        the coil calibration report of one channel (random, step)
* :mod:`.cal_time`   its time-series pages (step, sine)
* :mod:`.batch`      the network tables and report
* :mod:`.flags`      the flag rule the fit and batch reports share (off nominal)
* :mod:`.noise`      the self-noise pages (against the NLNM and NHNM)

May import core, io, criticism and coil; never network or cli.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "fit": ["load_result", "write_report"],
    "layout": ["A4", "ReportContext"],
    "batch": ["COLUMNS", "read_results", "results_table"],
    "flags": ["find_flags", "off_nominal"],
    "diagnosis": ["build_figure", "write_page"],
    "fit_pages": ["page_convergence", "page_data_fit", "page_summary"],
    "noise": ["figure_component", "write_figures"],
    "tables": ["angle_rows", "response_rows"],
})
