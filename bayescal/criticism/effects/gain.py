"""A sensitivity off its metadata value on one SUT channel (testable when
the gains are not fitted): that channel's ratio flat and off 1, its phase
0 (:func:`.screens.signatures`)."""
from __future__ import annotations

import numpy as np

from .base import CriticismEffect


class GainError(CriticismEffect):
    """SUT channel ``row``'s sensitivity is ``1 + fraction`` times its
    metadata value (only testable when gains are not fitted)."""

    name = "gain_error"
    param_names = ("fraction",)

    def __init__(self, row, channel_id=""):
        self.rows = [row]
        self.channel_id = channel_id

    def factor(self, f, p):
        return (1.0 / (1.0 + p[:, :1, None])) * np.ones_like(f)[None, None, :]

    def log_prior(self, p):
        return np.where(np.abs(p[:, 0]) < 0.9, 0.0, -np.inf)

    @staticmethod
    def physical(p):
        return {"fraction": p[:, 0]}

    def explain(self, med):
        return (f"{self.channel_id}'s sensitivity is {100 * med['fraction']:+.2g} % off its "
                "metadata value")
