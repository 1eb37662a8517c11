"""A fit's :class:`~bayescal.core.posterior.state.FitState` put together
from its model and samples: every kind of fit (the pair fit, a diagnosis's
final model) builds its state here."""
from __future__ import annotations

import numpy as np

from ..posterior.state import FitState

#: Sampled parameters of an axis -> what the result calls its kind.
KINDS = {2: "sphere", 1: "circle", 0: "fixed"}


def assemble_posterior(model, samples, log_prob, convergence, meta, free, *, names=None,
                       full=None, theta_ls=None, not_estimable=None, trace=None):
    """The :class:`~bayescal.core.posterior.state.FitState` of ``model``.

    ``samples`` (N, k) and ``log_prob`` (N,) as sampled, in the coordinates
    named ``names`` (None: the model's own); ``full`` (N, ndim) the same in
    the model's coordinates (None: ``samples``; it differs when parameters
    were held). Axes and responses (when ``free`` is not "none") are read
    from ``full``, the diagnostics at its median. ``convergence``:
    a :class:`~bayescal.result.convergence.Convergence`
    (:meth:`bayescal.core.sampling.mcmc.Chain.convergence`); ``meta``
    a dict or a :class:`~bayescal.result.meta.Meta`.
    """
    full = samples if full is None else full
    # axes only, a block of samples at a time (unpack's response factors
    # for every sample would set the fit's peak memory)
    vecs = np.concatenate([model.unpack(full[i:i + 256])[0]
                           for i in range(0, max(len(full), 1), 256)])
    theta = np.median(full, axis=0)
    return FitState(channel_ids=[b.channel_id for b in model.blocks],
                    kinds=[KINDS[b.manifold.n_params] for b in model.blocks], vectors=vecs,
                    response=model.response_values(full) if free != "none" else {},
                    samples=samples, names=list(model.names if names is None else names),
                    log_prob=log_prob, convergence=convergence, meta=meta,
                    not_estimable=not_estimable or {}, trace=trace,
                    diagnostics=diagnostics(model, theta), model=model, theta_ls=theta_ls,
                    full_samples=full)


def plugin_meta(model):
    """``meta.plugin_weights``: each band's likelihood weight for the plug-in
    noise model's own sampling error (:mod:`bayescal.core.model.plugin`)."""
    w = getattr(model.noise, "weight", None)
    return None if w is None else [round(float(v), 4) for v in w]


def diagnostics(model, theta):
    """Arrays a report or a model check needs, at parameter point ``theta``:
    spectra, coherences and the per-band standardised misfit."""
    sp = model.spectra
    return {"freqs": sp.freqs, "psd": sp.psd(), "multiple_coherence": sp.multiple_coherence(),
            "band_edges": sp.band_edges, "band_misfit": model.standardized_band_residuals(theta),
            "noise_inflation": model.noise.inflation,
            "sut_ids": np.array(sp.sut_ids), "ref_ids": np.array(sp.ref_ids)}
