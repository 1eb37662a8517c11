"""Self-noise of co-located sensors.

* :mod:`.sleeman`    three or more sensors (Sleeman), the Wishart-bootstrap
                     interval
* :mod:`.pair_noise` both sensors of a pair fit, from the fitted transfer

May import :mod:`bayescal.core.spectra`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "sleeman": ["SelfNoise", "acceleration_band_matrices", "below_resolution", "db",
                "estimate_self_noise", "period_band_weights"],
    "pair_noise": ["for_fit"],
})
