"""A pole missing from the metadata of the SUT or of the reference: the
per-band ratio's amplitude rolls off (or rises) and its phase lags (or
leads) toward high frequency (:func:`.screens.signatures`)."""
from __future__ import annotations

import numpy as np

from .base import CriticismEffect

#: A missing pole is named only with its corner below this many times the band top.
IDENTIFIABLE_RATIO = 3.0


class ExtraPole(CriticismEffect):
    """A real pole at ``corner_hz`` missing from the metadata of the SUT
    (``which="sut"``) or of the reference (``which="ref"``), normalised like
    the first stage (unit gain at ``norm_freq``). Parameter: ``1 / corner``
    in seconds (0 = no pole; the prior keeps it positive)."""

    name = "extra_pole"
    param_names = ("inverse_corner_s",)
    #: Along the grid, at the fit's point, a pole's likelihood has a
    #: maximum near its true corner and another at "no pole": the fit's
    #: orientation and gains have taken up part of the mismatch, so the
    #: second can be the higher there (an extra zero near 1.5 Hz, say).
    #: Each local maximum is a least-squares start.
    multimodal = True

    def __init__(self, rows, which, norm_freq=1.0, max_inverse_s=100.0):
        self.rows = list(rows)
        self.which = which
        self.norm_freq = norm_freq
        self.max_inverse_s = max_inverse_s

    def factor(self, f, p):
        x = p[:, :1, None]
        undo = (1 + 1j * f[None, None, :] * x) / np.abs(1 + 1j * self.norm_freq * x)
        return undo if self.which == "sut" else 1.0 / undo

    def log_prior(self, p):
        return np.where((p[:, 0] >= 0) & (p[:, 0] < self.max_inverse_s), 0.0, -np.inf)

    @staticmethod
    def identifiable(p, fmin, fmax):
        """A corner far above the band only adds a near-linear phase and a
        gain step (a delay and a gain): not identifiable as a pole there."""
        return p[0] * fmax * IDENTIFIABLE_RATIO >= 1.0

    @staticmethod
    def physical(p):
        with np.errstate(divide="ignore"):
            return {"corner_hz": 1.0 / np.maximum(p[:, 0], 1e-12)}

    def explain(self, med):
        who, other = (("sensor under test", "reference") if self.which == "sut"
                      else ("reference", "sensor under test"))
        return (f"the {who}'s response has a pole near {med['corner_hz']:.3g} Hz that its "
                "metadata lacks (its amplitude rolls off and its phase lags above that; a "
                f"pair of recordings cannot tell this from a zero missing from the {other}'s "
                "metadata)")
