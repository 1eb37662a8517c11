"""A record cut into windows, and the record's value from them.

* :mod:`.wander`  one parameter's window estimates as the record's value
                  plus a slow Ornstein-Uhlenbeck wander plus each window's
                  error: :func:`fit_wander` (Kalman filter, grid posterior)
* :mod:`.windows` a pair's record cut into consecutive windows, each fitted
                  by :mod:`bayescal.pair`: :func:`fit_windows`
* :mod:`.pooling` the record's noise inflation, a floor under each
                  window's: :func:`floor_windows`
* :mod:`.values`  each parameter's windows combined into the record's
                  value: :func:`combine`
* :mod:`.figure`  each parameter's windows against time, the record's
                  value and the wander's path: :func:`write_figure`

May import :mod:`bayescal.core`, :mod:`bayescal.io`, :mod:`bayescal.pair`,
:mod:`bayescal.report` and :mod:`bayescal.result`.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`)::

    from bayescal.record import fit_wander
    fit = fit_wander(medians, sds, times)
    fit.mu["ci95"], fit.tau["median"], fit.record      # the record's value, the wander, per window
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "wander": ["PRIOR", "WanderFit", "draw_wander", "fit_wander", "record_intervals", "widen_samples"],
    "windows": ["Window", "fit_windows"],
    "pooling": ["floor_windows", "record_floor"],
    "values": ["ParameterRecord", "combine"],
    "figure": ["build_figure", "write_figure"],
})
