"""A fit's :class:`~bayescal.result.record.Result` on disk, schema
``bayescal.fit/1``: ``result.json`` (the summary: per-channel estimates,
checks, convergence and ``meta``), ``samples.npz`` (samples,
log-probabilities, axes, responses, convergence arrays) and
``diagnostics.npz`` (spectra and misfits for reports), each written
atomically; :func:`load` reads the three back into the same Result.
"""
from __future__ import annotations

import json
import os

import numpy as np

from .convergence import Convergence
from .meta import Meta
from .record import SCHEMA, Result, jsonable


def save(result, folder):
    """Write ``result.json`` and ``samples.npz`` (and ``diagnostics.npz``
    when ``result`` holds diagnostics) into ``folder`` (created when
    missing); each file is written to a temporary name, then renamed.

    The npz files are stored uncompressed (:func:`numpy.savez`): draws are
    random doubles, which deflate shrinks only to about 0.6 of their size,
    for about 0.05 s of CPU on a 2-hour pair fit's 4000 draws."""
    os.makedirs(folder, exist_ok=True)
    arrays = {"samples": result.samples, "log_prob": result.log_prob,
              "vectors": result.vectors}
    for cid, r in result.response.items():
        arrays[f"response::{cid}"] = r
    if result.trace is not None:
        arrays["trace"] = result.trace
    extra = {"channel_ids": result.channel_ids, "kinds": result.kinds, "names": result.names,
             "convergence": jsonable(result.convergence.to_dict())}
    from ..atomic import atomic_path     # here: reading a result needs none of it

    with atomic_path(os.path.join(folder, "samples.npz")) as tmp:
        np.savez(tmp, extra=json.dumps(extra), **arrays)
    if result.diagnostics:
        with atomic_path(os.path.join(folder, "diagnostics.npz")) as tmp:
            np.savez(tmp, **{k: np.asarray(v) for k, v in result.diagnostics.items()})
    write_json(os.path.join(folder, "result.json"), result.summary())


def load(folder):
    """The :class:`~bayescal.result.record.Result` that :func:`save` wrote
    into ``folder`` (its summaries as ``result.json`` holds them)."""
    with open(os.path.join(folder, "result.json")) as fh:
        s = json.load(fh)
    _check_schema(s.get("schema"), folder)
    with np.load(os.path.join(folder, "samples.npz")) as z:
        extra = json.loads(str(z["extra"]))
        response = {k.split("::", 1)[1]: z[k] for k in z.files if k.startswith("response::")}
        arrays = {k: z[k] for k in ("vectors", "samples", "log_prob")}
        trace = z["trace"] if "trace" in z.files else None
    diagnostics = {}
    path = os.path.join(folder, "diagnostics.npz")
    if os.path.exists(path):
        with np.load(path) as z:
            diagnostics = {k: z[k] for k in z.files}
    meta = Meta.from_dict({**s.get("meta", {}), "multimodal": s.get("multimodal")})
    return Result(channel_ids=extra["channel_ids"], kinds=extra["kinds"], names=extra["names"],
                  response=response, convergence=Convergence.from_dict(extra["convergence"]),
                  meta=meta, channels=s.get("channels", {}),
                  orthogonality_deg=s.get("orthogonality_deg", {}),
                  adequacy=s.get("adequacy", {}), not_estimable=s.get("not_estimable", {}),
                  trace=trace, diagnostics=diagnostics, self_noise=s.get("self_noise", {}),
                  sensor_order=s.get("sensor_order", {}), criticism=s.get("criticism", {}),
                  rejected=s.get("rejected_fit", {}),
                  response_curve=s.get("response_curve", {}),
                  **arrays)


def _check_schema(name, folder):
    """Refuse a ``result.json`` of another kind or of a later version of the
    schema than :data:`~bayescal.result.record.SCHEMA` (an earlier one is
    read as far as it goes)."""
    kind, _, version = str(name).partition("/")
    ours, _, current = SCHEMA.partition("/")
    if kind != ours or not version.isdigit() or int(version) > int(current):
        from ..errors import InputError

        raise InputError(f"{folder}: result.json is of schema {name!r}; this version of "
                         f"bayescal reads {SCHEMA!r} and earlier")


def write_json(path, obj):
    """Write ``obj`` as JSON (:func:`jsonable` values) atomically
    (:func:`bayescal.atomic.write_json`)."""
    from .. import atomic

    atomic.write_json(path, jsonable(obj))


#: The name :func:`bayescal.load_posterior` gives :func:`load`.
load_posterior = load
