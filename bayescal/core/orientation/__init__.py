"""Channel orientations.

* :mod:`.geometry`    angles <-> unit vectors (NED), SEED conventions, manifolds
* :mod:`.tilt_region` credible statements about a near-vertical channel's tilt

Imports no other part of :mod:`bayescal.core`.
"""
