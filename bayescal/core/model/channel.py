"""How one channel of the sensor under test enters a pair model: its
orientation parameters, which of its response parameters are free, and
their names and bounds."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..response import pendulum
from ..response.family import TwoPoleFamily, gain_prior_factor


@dataclass(frozen=True)
class ChannelBlock:
    """How one SUT channel enters the model.

    ``manifold`` (from :mod:`bayescal.core.orientation.geometry`) holds its orientation
    parameters; ``free`` is ``"none"``, ``"gain"`` or ``"all"`` (period,
    damping, gain: sampled as ``c0_rel``, ``c1_rel``, ``log_gain``, see
    :mod:`bayescal.core.response.pendulum`); ``family`` is the channel's parametric
    response.
    """

    channel_id: str
    manifold: object
    family: TwoPoleFamily | None
    free: str = "none"

    @property
    def n_response(self):
        return {"none": 0, "gain": 1, "all": 3}[self.free]

    @property
    def n_params(self):
        return self.manifold.n_params + self.n_response

    def param_names(self):
        orient = {2: ["orient_a", "orient_b"], 1: ["azimuth_rad"], 0: []}[self.manifold.n_params]
        resp = {"none": [], "gain": ["log_gain"], "all": [*pendulum.NAMES, "log_gain"]}[self.free]
        return [f"{self.channel_id}:{p}" for p in orient + resp]

    def response_bounds(self, priors):
        """(lo, hi) of the channel's response parameters under ``priors``:
        the gain's log-uniform range, ``c0_rel``, ``c1_rel`` positive."""
        lo, hi = np.full(self.n_response, -np.inf), np.full(self.n_response, np.inf)
        if self.free != "none":
            g = np.log(self.family.gain)
            wide = np.log(gain_prior_factor(self.family, priors))
            lo[-1], hi[-1] = g - wide, g + wide
        if self.free == "all":       # c0_rel, c1_rel: positive (their prior is not a box)
            lo[:2] = 0.0
        return lo, hi
