"""The second step of a pair fit: the model, its least-squares point, the
posterior samples and their convergence, from a :class:`~.prepare.PairData`
(:func:`bayescal.core.fit.run.fit_spectra`)."""
from __future__ import annotations

from ..core.fit.run import fit_spectra
from ..core.model.likelihood import Priors
from ..io.band import MIN_COHERENCE
from ..io.read import InputError


def fit(data, *, fit_response="gain", priors=Priors(), seed=0, ref_noise=None, progress=True,
        **sample_kw):
    """The :class:`~bayescal.core.posterior.state.FitState` of ``data``.

    The options are :func:`bayescal.calibrate`'s of the same names;
    ``sample_kw`` go to :func:`bayescal.core.fit.run.fit_spectra` (e.g.
    ``max_steps``, ``misfit_shape``). A channel set aside for want of
    coherence is listed in the state's ``not_estimable``; the reference's
    self-noise as given is the meta's ``reference_noise["input"]``.
    """
    if data.known_noise is not None:
        if ref_noise not in (None, "fixed"):
            raise InputError(f"--ref-noise {ref_noise} and --ref-noise-psd both say how to "
                             "treat the reference's noise: give one")
        ref_noise = "fixed"
    state = fit_spectra(data.fitted, data.ref_vectors, data.sut_vectors, data.families,
                        free=fit_response, priors=priors, seed=seed, progress=progress,
                        meta=data.meta, ref_noise=ref_noise, known_noise=data.known_noise,
                        **sample_kw)
    meta = state.meta
    given = data.meta.get("reference_noise_input")
    if given is not None:
        meta = meta.replace(reference_noise=dict(meta.reference_noise or {}, input=given))
    low = {cid: (f"no coherence with the reference in the band (mean multiple coherence "
                 f"{c:.3f}, needed {MIN_COHERENCE:g})") for cid, c in data.low.items()}
    return state.replace(meta=meta, not_estimable={**state.not_estimable, **low},
                         spectra=data.spectra, sut_inventory=data.sut_inventory)
