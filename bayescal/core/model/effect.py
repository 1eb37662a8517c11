"""The hook by which a physical effect the base model leaves out extends
the likelihood (:class:`Effect`; the catalogue is in
:mod:`bayescal.criticism.effects`)."""
from __future__ import annotations

import numpy as np


class Effect:
    """A physical effect the base model leaves out, as an extension of it.

    An effect multiplies the SUT deconvolution factor of the channels
    ``rows`` (indices into the model's SUT channels) by ``factor(freqs, p)``,
    a complex array of shape (W, len(rows), F) or broadcastable to it, for
    parameters ``p`` of shape (W, n_params). An effect on the reference (a
    pole missing from its metadata, its clock) is expressed on the SUT side as
    the reciprocal factor applied to every row. ``factor`` must be 1 at the
    effect's null value, so the extended model nests the base model.
    An effect that is a clock (the SUT's timing against the reference's),
    not a response, sets ``time_correction = True`` (:func:`is_clock`): the
    response as the data see it leaves its factor out and reports it as a
    time correction of the data.
    Subclasses set ``name``, ``param_names``, ``rows`` and implement
    ``factor`` and ``log_prior`` (vectorised, -inf outside the support).
    An effect with a proper prior may give its least-squares rows,
    ``prior_residual(p) -> (r, J)`` for ``p`` (n_params,), ``|r|^2`` its
    ``-log prior`` up to a constant: least squares then finds the
    posterior's mode and its Laplace precision
    (:func:`bayescal.core.model.jacobian.least_squares_objective`).

    An effect that changes through the record (a drifting clock) sets
    ``blocked = True``; its ``factor`` then returns one factor per time block
    of the spectra (``CrossSpectra.block_totals``), shape (W, G, len(rows), F)
    or broadcastable to it.
    """

    name = "effect"
    param_names: tuple = ()
    rows: list = []
    blocked = False

    @property
    def n_params(self):
        return len(self.param_names)

    def factor(self, freqs, p):
        raise NotImplementedError

    def log_prior(self, p):
        return np.zeros(p.shape[0])


#: Effects that are a clock, not a response, by name (an effect may also say
#: so itself: ``time_correction``).
CLOCK_EFFECTS = ("timing_offset", "clock_drift")


def is_clock(effect):
    """Whether ``effect`` is a clock (a time correction of the data), not a
    response: its own ``time_correction`` flag when it sets one, else its
    name in :data:`CLOCK_EFFECTS`."""
    return bool(getattr(effect, "time_correction", effect.name in CLOCK_EFFECTS))
