"""The priors of every fit: one small, explicit, frozen record (pair fits,
coil calibrations and the criticism's refits share it)."""
from __future__ import annotations

from dataclasses import dataclass

from .response.pendulum import DAMPING_TOLERANCE, PERIOD_TOLERANCE


@dataclass(frozen=True)
class Priors:
    """Explicit, documented priors.

    Orientation: uniform on the sphere (or on the circle of a two-channel
    reference). Natural period and damping (pair fits and coil
    calibrations): each log-normal around its nominal value with relative
    standard deviation ``period_tolerance`` and ``damping_tolerance`` (the
    manufacturer's tolerance; :mod:`bayescal.core.response.pendulum`). Gain:
    log-uniform in ``[G_nom / gain_factor, G_nom * gain_factor]``. The
    reference's gain, period and damping: exact (``reference_tolerance``
    0) or log-normal with that relative standard deviation
    (:mod:`bayescal.core.response.reference_tolerance`).
    """

    gain_factor: float = 10.0
    period_tolerance: float = PERIOD_TOLERANCE
    damping_tolerance: float = DAMPING_TOLERANCE
    reference_tolerance: float = 0.0
