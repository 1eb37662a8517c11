"""The one interface of every model bayescal fits: a pair model
(:class:`bayescal.core.model.likelihood.Model`, :class:`bayescal.core.model.eiv.EIVModel`),
a coil run model (:class:`bayescal.coil.element.RunModel` and the random,
step and sine models built on it or on the time-domain model) and each
element of a UVW calibration.

Least squares needs the parameters' ``names``, their ``bounds`` and a
``likelihood_residual``; the sampler (:func:`bayescal.core.sampling.mcmc.sample`)
needs ``ndim`` and a vectorised ``log_prob``; the plug-in noise model is
set by ``estimate_noise`` at a point and held fixed while sampling.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable


@runtime_checkable
class PosteriorModel(Protocol):
    """What a model offers the least squares and the sampler.

    Attributes
    ----------
    names : sequence of str, one per parameter of ``theta``.
    ndim : int, the number of parameters.
    """

    names: Sequence[str]
    ndim: int

    def bounds(self):
        """``(lo, hi)``, each (ndim,): the box the prior allows (infinite
        where it is unbounded)."""

    def log_prob(self, theta):
        """Log posterior, vectorised: ``theta`` (W, ndim) -> (W,)."""

    def likelihood_residual(self, theta):
        """The whitened residual at one ``theta`` (ndim,) with the noise
        model as set, (m,) real: ``-log L`` is its squared norm times the
        model's ``LIKELIHOOD_SCALE`` (1 where the model does not set it)."""

    def estimate_noise(self, theta):
        """Estimate the plug-in noise model at ``theta`` and hold it."""
