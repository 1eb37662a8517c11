"""A fit's result: what is saved and read back, frozen once built."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .labels import describe, parameter_label
from .convergence import Convergence
from .meta import Meta, by_channel

SCHEMA = "bayescal.fit/1"
#: Nominal dip (degrees, absolute) from which a channel's tangent-plane
#: coordinates are tilts toward east and north (the basis switches where the
#: axis' down component reaches 0.9: arcsin 0.9 = 64.16 degrees).
VERTICAL_DIP_DEG = float(np.degrees(np.arcsin(0.9)))
#: ``multimodal`` of a fit that did not search for modes.
NOT_SEARCHED = {"detected": None, "note": "not searched for this kind of fit"}


@dataclass(frozen=True)
class Result:
    """Samples of one fit, their summaries and what was run.

    Attributes
    ----------
    channel_ids : fitted SUT channels (SEED ids), in order.
    kinds : per channel "sphere" (azimuth and dip estimated), "circle"
        (azimuth in the reference's plane) or "fixed" (response only).
    vectors : (N, n_ch, 3) sampled channel axes (NED).
    response : channel id -> (N, 3) period_s, damping, gain samples; only
        for channels whose response was fitted. With the reference's
        tolerance stated (``meta.reference_tolerance``) each channel's rows
        are resampled on their own: they do not pair across channels or
        with ``samples``/``vectors``.
    samples, names, log_prob : raw sampler output in model coordinates;
        ``names`` are the sampler's keys (``"<channel id>:orient_a"``),
        :attr:`labels` says what each one is.
    convergence : :class:`~bayescal.result.convergence.Convergence`.
    meta : :class:`~bayescal.result.meta.Meta`: band, data used, reference
        noise, sampler, nominal values, ...
    channels : channel id -> its summary (``result.json``'s ``channels``:
        azimuth, dip or tilt, response, with credible intervals).
    orthogonality_deg, adequacy : ``result.json``'s entries of the same names.
    not_estimable, self_noise, sensor_order, criticism : the same.
    response_curve : each SUT channel's response relative to the
        reference's metadata under the headline model, with the metadata's
        ratio beside it and the clock effects as a time correction
        (``result.json``'s ``response_curve``,
        :func:`bayescal.pair.response_curve.relative_response`); empty when
        not computed.
    rejected : the fit the criticism's verdict rejected when the improved
        model heads the result (``meta.headline``), as ``result.json``'s
        ``rejected_fit`` holds it (its channels, orthogonality, model check
        and convergence); empty when the fit is the headline.
    diagnostics : arrays a report or a model check needs (``diagnostics.npz``).
    trace : the chain's per-step trace, when kept.

    Notes
    -----
    A result just fitted also holds, in memory only (None when read back
    from disk): ``improved``, the :class:`Result` of the criticism's
    improved model, and ``state``, the live fit
    (:class:`bayescal.core.posterior.state.FitState`: its model,
    least-squares point, full samples, spectra and the SUT's metadata). When
    the improved model heads the result, ``state`` stays the fit the
    criticism started from (its model is not the headline's: the improved
    model's live state is ``improved.state``).

    ``print(result)`` shows each channel's medians and 95 % intervals, the
    model check and the convergence in a few lines; ``summary()`` is
    ``result.json``'s content.
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
    channels: dict
    orthogonality_deg: dict = field(default_factory=dict)
    adequacy: dict = field(default_factory=dict)
    not_estimable: dict = field(default_factory=dict)
    trace: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    self_noise: dict = field(default_factory=dict)
    sensor_order: dict = field(default_factory=dict)
    criticism: dict = field(default_factory=dict)
    rejected: dict = field(default_factory=dict)
    response_curve: dict = field(default_factory=dict)
    improved: object = field(default=None, repr=False, compare=False)
    state: object = field(default=None, repr=False, compare=False)

    @property
    def sut_inventory(self):
        """The SUT's metadata the fit read (None when read from disk)."""
        return None if self.state is None else self.state.sut_inventory

    @property
    def labels(self):
        """What each sampled parameter is, in the order of ``names``
        (``"BH1 azimuth offset (tangent plane, rad)"``, ``"BHZ log gain"``)."""
        return [parameter_label(name, vertical=self._vertical(name.rpartition(":")[0]))
                for name in self.names]

    def _vertical(self, cid):
        dip = ((self.channels.get(cid) or {}).get("nominal") or {}).get("dip_deg")
        return dip is not None and abs(float(dip)) >= VERTICAL_DIP_DEG

    def __repr__(self):
        """One line: the channels, the sample count and the model check."""
        check = {True: "passed", False: "failed"}.get((self.adequacy or {}).get("ok"), "not run")
        return (f"<bayescal Result: {', '.join(self.channel_ids)}; {len(self.samples)} samples "
                f"of {len(self.names)} parameters; model check {check}>")

    def __str__(self):
        """Each channel's medians and 95 % intervals, the model check and
        the convergence, in a few lines (``print(result)``)."""
        return describe(self)

    def summary(self):
        """The ``result.json`` content (schema ``bayescal.fit/1``): plain
        JSON values (dicts, lists, str, float, int, bool, None)."""
        return jsonable({
            "schema": SCHEMA,
            "adequacy": self.adequacy,
            "multimodal": self.meta.multimodal or NOT_SEARCHED,
            "channels": self.channels,
            "not_estimable": self.not_estimable,
            "set_by_prior": {cid: {k: v["reason"] for k, v in e.items()} for cid, e in
                             by_channel(self.meta.set_by_prior).items()},
            "orthogonality_deg": self.orthogonality_deg,
            **({"self_noise": self.self_noise} if self.self_noise else {}),
            **({"sensor_order": self.sensor_order} if self.sensor_order else {}),
            **({"criticism": self.criticism} if self.criticism else {}),
            **({"rejected_fit": self.rejected} if self.rejected else {}),
            **({"response_curve": self.response_curve} if self.response_curve else {}),
            "convergence": self.convergence.summary(self.names),
            "meta": self.meta.to_dict(multimodal=False),
        })


def jsonable(obj):
    """``obj`` as plain JSON values: numpy arrays as lists, numpy scalars as
    Python numbers, non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return obj


#: The public name of a fit's result (``bayescal.Posterior``).
Posterior = Result
