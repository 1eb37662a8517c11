"""Channel orientations.

* :mod:`.geometry`    angles <-> unit vectors (NED), SEED conventions, manifolds
* :mod:`.tilt_region` credible statements about a near-vertical channel's tilt

Imports no other part of :mod:`bayescal.core`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "geometry": ["Circle", "Fixed", "Sphere", "NEAR_VERTICAL_DIP_DEG", "STS2_UVW", "TRILLIUM_UVW",
                 "azimuth_dip", "tilt_components", "tilt_from_vertical", "unit_vector",
                 "unwrap_azimuths"],
    "tilt_region": ["REGION_NOTE", "lean_region", "tilt_intervals"],
})
