"""What a fit ran, by name: the ``meta`` entry of ``result.json``.

Each entry is a field of :class:`Meta`; an entry a fit did not make is
None and is not written. Entries whose content is a table of their own
(``data_used``, ``reference_noise``, ``sampler``, ...) stay plain JSON
values (dicts and lists), as ``result.json`` holds them.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

#: One line per field, in the order ``result.json`` lists them.
FIELDS = {
    "nominal": "channel id -> the SUT's metadata: azimuth_deg, dip_deg and its response "
               "(period_s, damping, gain, gain_units)",
    "reference": "channel id -> the reference's azimuth_deg and dip_deg",
    "starttime": "start of the aligned recordings (ISO time)",
    "sampling_rate": "samples per second",
    "duration_s": "length of the aligned recordings",
    "data_used": "segments used of those possible, and the transients left out",
    "record_length": "whether the record is long enough for the band's lower edge",
    "band_choice": "how the band was chosen",
    "placeholder_response": "the channels whose metadata are bayescal placeholders",
    "files": "the waveform files of each side",
    "reference_noise_input": "the reference's self-noise as given (--ref-noise-psd)",
    "free_response": "what of the response was fitted: none, gain or all",
    "assumption": "what the fit assumed (the orthogonal-pair rotation)",
    "method": "how the posterior was computed, when not by MCMC",
    "band_hz": "(fmin, fmax) of the band fitted",
    "band_edges_hz": "edges of the fitted bands",
    "n_segments": "Welch segments used",
    "n_segments_possible": "Welch segments the record holds",
    "segment_s": "length of a Welch segment",
    "noise_inflation": "each band's noise inflation",
    "plugin_weights": "each band's weight for the plug-in noise model's sampling error",
    "reference_noise": "how the reference's self-noise was treated (mode, who chose it)",
    "misfit_scale": "the prior of the per-band noise scale and each band's factor",
    "least_squares": "parameter name -> its least-squares value",
    "approximation": "the approximation that replaced the sampler",
    "posterior_failed": "why the posterior could not be characterised",
    "mcmc_not_converged": "the improved model's chain stopped before converging",
    "set_by_prior": "parameter -> why its value is the prior's, not the data's",
    "multimodal": "the modes found (result.json holds it beside meta)",
    "prior_sensitivity": "how far the reported period and damping follow their prior",
    "response_prior": "the priors of period and damping",
    "effects": "the effects an improved model holds",
    "sampler": "what sampled the posterior: library, walkers, moves, steps",
    "budgets": "each stage's work budget (least squares, mode search, sampling): its limit "
               "and the work used, in model evaluations, and what ended it",
    "reference_tolerance": "the reference's metadata tolerance carried into the response",
    "batch_label": "the batch item's label",
    "headline": "under which model the reported estimates are: the fit's, or the criticism's "
                "improved model (its effects, and the verdict that chose it)",
}


@dataclass(frozen=True)
class Meta:
    """What a fit ran (the fields and their meaning: :data:`FIELDS`).

    ``nulls`` names the entries held as JSON null (an entry made but
    empty, e.g. ``plugin_weights`` of a model without plug-in weights);
    ``extra`` keeps any entry this schema does not name."""

    nominal: dict | None = None
    reference: dict | None = None
    starttime: str | None = None
    sampling_rate: float | None = None
    duration_s: float | None = None
    data_used: dict | None = None
    record_length: dict | None = None
    band_choice: str | None = None
    placeholder_response: dict | None = None
    files: dict | None = None
    reference_noise_input: dict | None = None
    free_response: str | None = None
    assumption: str | None = None
    method: str | None = None
    band_hz: list | None = None
    band_edges_hz: object = None
    n_segments: int | None = None
    n_segments_possible: int | None = None
    segment_s: float | None = None
    noise_inflation: object = None
    plugin_weights: list | None = None
    reference_noise: dict | None = None
    misfit_scale: dict | None = None
    least_squares: dict | None = None
    approximation: str | None = None
    posterior_failed: str | None = None
    mcmc_not_converged: bool | None = None
    set_by_prior: dict | None = None
    multimodal: dict | None = None
    prior_sensitivity: dict | None = None
    response_prior: dict | None = None
    effects: list | None = None
    sampler: dict | None = None
    budgets: list | None = None
    reference_tolerance: dict | None = None
    batch_label: str | None = None
    headline: dict | None = None
    nulls: frozenset = field(default=frozenset(), repr=False)
    extra: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_dict(cls, d):
        """From a ``meta`` dict (as ``result.json`` holds it)."""
        if isinstance(d, cls):
            return d
        d = dict(d or {})
        named = {k: d.pop(k) for k in list(d) if k in FIELDS}
        return cls(**named, nulls=frozenset(k for k, v in named.items() if v is None),
                   extra=d)

    def replace(self, **changes):
        """A copy with ``changes`` (field name -> value; a name this schema
        does not know goes to ``extra``)."""
        known = {k: v for k, v in changes.items() if k in FIELDS}
        other = {k: v for k, v in changes.items() if k not in FIELDS}
        nulls = (self.nulls - set(known)) | {k for k, v in known.items() if v is None}
        return replace(self, **known, nulls=frozenset(nulls),
                       extra={**self.extra, **other} if other else self.extra)

    def to_dict(self, multimodal=True):
        """The entries made, in :data:`FIELDS` order, then ``extra``;
        ``multimodal=False`` leaves out the modes (result.json holds them
        beside meta)."""
        out = {}
        for f in fields(self):
            if f.name not in FIELDS or (f.name == "multimodal" and not multimodal):
                continue
            v = getattr(self, f.name)
            if v is not None or f.name in self.nulls:
                out[f.name] = v
        out.update(self.extra)
        return out


#: Response parameter names in model coordinates -> physical names.
PHYSICAL = {"log_gain": "gain"}


def by_channel(set_by_prior):
    """``{channel id: {physical name: entry}}`` from a :attr:`Meta.set_by_prior`
    (``"<channel id>:<parameter>"`` -> entry)."""
    out = {}
    for name, entry in (set_by_prior or {}).items():
        cid, par = name.rsplit(":", 1)
        out.setdefault(cid, {})[PHYSICAL.get(par, par)] = entry
    return out
