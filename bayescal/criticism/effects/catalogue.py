"""The catalogue: every effect of the criticism by its name (a clock
drift's by its per-block form). A new effect's class is added here."""
from __future__ import annotations

from .corner import SutCorner
from .drift import ClockDrift
from .gain import GainError
from .pole import ExtraPole
from .response_parameters import ResponseParameters
from .timing import TimingOffset

#: The effects by name (a clock drift's by its per-block form).
CATALOGUE = {cls.name: cls for cls in (TimingOffset, ClockDrift, ExtraPole, GainError,
                                       ResponseParameters, SutCorner)}
