"""A fit's result on disk: ``result.json`` (the summary), ``samples.npz``
(samples, log-probabilities, axes, responses, convergence arrays) and
``diagnostics.npz`` (spectra and misfits for reports), written atomically
and read back into a :class:`~bayescal.core.posterior.samples.Posterior`.

Reading a result imports no model, spectra or sampling module.
"""
from __future__ import annotations

import json
import os

import numpy as np

from ..core.posterior import Posterior, jsonable


def save_posterior(post, folder):
    """Write ``result.json`` and ``samples.npz`` (and ``diagnostics.npz``
    when the posterior holds diagnostics) into ``folder`` atomically (each
    file is written to a temporary name, then renamed)."""
    os.makedirs(folder, exist_ok=True)
    arrays = {"samples": post.samples, "log_prob": post.log_prob, "vectors": post.vectors}
    for cid, r in post.response.items():
        arrays[f"response::{cid}"] = r
    if post.trace is not None:
        arrays["trace"] = post.trace
    extra = {"channel_ids": post.channel_ids, "kinds": post.kinds, "names": post.names,
             "convergence": jsonable(post.convergence)}
    tmp = os.path.join(folder, ".samples.tmp.npz")
    np.savez_compressed(tmp, extra=json.dumps(extra), **arrays)
    os.replace(tmp, os.path.join(folder, "samples.npz"))
    if post.diagnostics:
        tmp = os.path.join(folder, ".diagnostics.tmp.npz")
        np.savez_compressed(tmp, **{k: np.asarray(v) for k, v in post.diagnostics.items()})
        os.replace(tmp, os.path.join(folder, "diagnostics.npz"))
    write_json(os.path.join(folder, "result.json"), post.summary())


def load_posterior(folder):
    """The :class:`~bayescal.core.posterior.samples.Posterior` that
    :func:`save_posterior` wrote into ``folder``."""
    with open(os.path.join(folder, "result.json")) as fh:
        summary = json.load(fh)
    with np.load(os.path.join(folder, "samples.npz")) as z:
        extra = json.loads(str(z["extra"]))
        response = {k.split("::", 1)[1]: z[k] for k in z.files if k.startswith("response::")}
        conv = {k: (np.asarray(v) if isinstance(v, list) else v)
                for k, v in extra["convergence"].items()}
        post = Posterior(channel_ids=extra["channel_ids"], kinds=extra["kinds"],
                         vectors=z["vectors"], response=response, samples=z["samples"],
                         names=extra["names"], log_prob=z["log_prob"], convergence=conv,
                         meta={**summary.get("meta", {}), "multimodal": summary.get("multimodal")},
                         not_estimable=summary.get("not_estimable", {}),
                         trace=z["trace"] if "trace" in z.files else None,
                         self_noise=summary.get("self_noise", {}),
                         sensor_order=summary.get("sensor_order", {}),
                         criticism=summary.get("criticism", {}))
    diag = os.path.join(folder, "diagnostics.npz")
    if os.path.exists(diag):
        with np.load(diag) as z:
            post.diagnostics = {k: z[k] for k in z.files}
    return post


def write_json(path, obj):
    """Write ``obj`` as JSON atomically (temporary file, then rename)."""
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(jsonable(obj), fh, indent=2)
    os.replace(tmp, path)
