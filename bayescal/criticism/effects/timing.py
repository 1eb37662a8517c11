"""A timing offset: the SUT's clock late (or early) by a constant time
against the reference's. Signature: the phase of the per-band ratio linear
in frequency through the origin, its amplitude flat
(:func:`.screens.signatures`)."""
from __future__ import annotations

import numpy as np

from .base import CriticismEffect


class TimingOffset(CriticismEffect):
    """The SUT's clock is late by ``seconds`` relative to the reference's."""

    name = "timing_offset"
    param_names = ("seconds",)
    multimodal = True

    def __init__(self, rows, limit_s=30.0):
        self.rows = list(rows)
        self.limit_s = limit_s

    def factor(self, f, p):
        return np.exp(2j * np.pi * f[None, None, :] * p[:, :1, None])

    def log_prior(self, p):
        return np.where(np.abs(p[:, 0]) < self.limit_s, 0.0, -np.inf)

    @staticmethod
    def physical(p):
        return {"seconds": p[:, 0]}

    @staticmethod
    def explain(med):
        s = med["seconds"]
        return (f"the SUT's clock is {abs(s):.3g} s {'late' if s > 0 else 'early'} relative to "
                "the reference's (a timing offset between the digitizers)")
