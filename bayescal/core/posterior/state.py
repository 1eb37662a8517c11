"""A fit in memory: its samples with the live objects a refit, a model
check or a criticism needs, and the frozen
:class:`~bayescal.result.record.Result` built from it."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ...result.convergence import Convergence
from ...result.meta import Meta
from ...result.record import Result
from ..checks.adequacy import from_diagnostics
from .samples import channel_summaries, orthogonality


@dataclass
class FitState:
    """One fit as it comes from its sampler.

    The fields a :class:`~bayescal.result.record.Result` saves
    (``channel_ids``, ``kinds``, ``vectors``, ``response``, ``samples``,
    ``names``, ``log_prob``, ``convergence``, ``meta``, ``not_estimable``,
    ``trace``, ``diagnostics``), and the live ones it does not: ``model``
    (the likelihood it sampled; None for a fit without one), ``theta_ls``
    (its least-squares point), ``full_samples`` (the samples in the model's
    coordinates, held parameters included), ``spectra`` (the cross-spectra
    of every SUT channel) and ``sut_inventory`` (the SUT's metadata, for the
    corrected StationXML).
    """

    channel_ids: list
    kinds: list
    vectors: np.ndarray
    response: dict
    samples: np.ndarray
    names: list
    log_prob: np.ndarray
    convergence: Convergence
    meta: Meta
    not_estimable: dict = field(default_factory=dict)
    trace: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False, compare=False)
    theta_ls: np.ndarray | None = field(default=None, repr=False, compare=False)
    full_samples: np.ndarray | None = field(default=None, repr=False, compare=False)
    spectra: object = field(default=None, repr=False, compare=False)
    sut_inventory: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        self.convergence = Convergence.from_dict(self.convergence)
        self.meta = Meta.from_dict(self.meta)

    def to_result(self, **changes):
        """The frozen :class:`~bayescal.result.record.Result` of this fit,
        its summaries computed once; ``changes``: fields of the Result that
        differ from the fit's (``response``, ``meta``, ``self_noise``,
        ``sensor_order``, ``criticism``, ``improved``, ...)."""
        saved = {k: getattr(self, k) for k in (
            "channel_ids", "kinds", "vectors", "response", "samples", "names", "log_prob",
            "convergence", "meta", "not_estimable", "trace", "diagnostics")}
        saved.update(changes)
        saved.setdefault("state", self)
        view = _View(saved)
        return Result(**saved, channels=channel_summaries(view),
                      orthogonality_deg=orthogonality(view),
                      adequacy=from_diagnostics(saved["diagnostics"]))

    def summary(self):
        """The ``result.json`` content this fit would have as it stands."""
        return self.to_result().summary()

    def replace(self, **changes):
        """A copy with ``changes``."""
        return replace(self, **changes)


class _View:
    """Attribute access to the fields a Result is built from."""

    def __init__(self, fields):
        self.__dict__.update(fields)
