"""The second step of a pair fit: the model, its least-squares point, the
posterior samples and their convergence, from a :class:`~.preparation.PairData`
(:func:`bayescal.core.fit.run.fit_spectra`).

What of the response is fitted (``fit_response``): "gain" (the default:
angles and each SUT channel's gain, reported also as a relative gain,
fitted / metadata, which is what a relative-gain experiment measures; works
with ``flat`` metadata too), "all" (period, damping and gain per channel;
needs a poles-and-zeros first stage) or "none" (angles only, gains held at
their metadata values). With a one-channel horizontal reference the gains
are held whatever is asked short of "all" (see :mod:`bayescal.core.fit.rotation`).

How the reference's own self-noise is treated (``ref_noise``): "quiet"
(negligible next to the SUT's), "estimate" (estimated from the data: white
in ground units plus white in its counts) or "equal" (the same as the SUT's
in ground units); None (the default): "estimate" with two or more channels
on each side (unbiased whatever the split of noise), "quiet" otherwise (a
one-channel pair cannot separate the reference's noise); see
:mod:`bayescal.core.model.refnoise`. With the reference's self-noise given
(``ref_noise_psd``) it is "fixed".
"""
from __future__ import annotations

from dataclasses import replace

from ..core.fit import fit_spectra
from ..core.priors import Priors
from ..core.response import pendulum_pairs, sampling_tolerances
from ..io.band import MIN_COHERENCE
from ..errors import InputError


def sampling_priors(data, priors, fit_response):
    """The priors the fit of ``data`` samples with: ``priors``, their period
    and damping tolerances widened by the reference's error where its
    tolerance is stated and they are fitted
    (:func:`bayescal.core.response.sampling_tolerances`; the stated ones
    are weighed back in by :func:`bayescal.pair.choice.choose`)."""
    if not priors.reference_tolerance or fit_response != "all":
        return priors
    pairs = pendulum_pairs(data.families, data.sut_vectors, data.ref_vectors, data.ref_families)
    if not pairs:
        return priors
    t, h = sampling_tolerances(priors.reference_tolerance, pairs, priors.period_tolerance,
                               priors.damping_tolerance)
    return replace(priors, period_tolerance=t, damping_tolerance=h)


def stated_prior(meta, priors):
    """``meta`` (a fit's) with its ``response_prior`` the stated ``priors``'
    period and damping tolerances, and those it sampled with under
    ``sampled_with`` where they differ (:func:`sampling_priors`)."""
    rp = meta.response_prior
    stated = {"period_tolerance": priors.period_tolerance,
              "damping_tolerance": priors.damping_tolerance}
    if not rp or all(rp[k] == v for k, v in stated.items()):
        return meta
    sampled = {k: rp[k] for k in stated}
    return meta.replace(response_prior={**rp, **stated, "sampled_with": sampled})


def fit(data, *, fit_response="gain", priors=Priors(), seed=0, ref_noise=None, progress=True,
        **sample_kw):
    """The :class:`~bayescal.core.posterior.state.FitState` of ``data``.

    Parameters
    ----------
    data : PairData
        From :func:`bayescal.pair.preparation.prepare`.
    fit_response : {"gain", "none", "all"}
        What of the response is fitted (module docstring).
    priors : bayescal.core.priors.Priors
        The priors; with ``fit_response="all"`` its ``period_tolerance`` and
        ``damping_tolerance`` (relative standard deviations of the log-normal
        priors on period and damping, default 0.05) are the manufacturer's
        tolerance (:mod:`bayescal.core.response.pendulum`); its
        ``reference_tolerance`` (default 0: the reference's metadata taken as
        exact) the relative standard deviation of the reference's gain,
        period and damping, carried into the SUT's response intervals by
        :func:`bayescal.pair.choice.choose`
        (:mod:`bayescal.core.response.reference_tolerance`; the fit then
        samples with wider period and damping priors, :func:`sampling_priors`).
    seed : int
        Random seed (results are reproducible).
    ref_noise : {None, "estimate", "quiet", "equal"}
        How the reference's own self-noise is treated (module docstring);
        the mode used is in ``result.meta.reference_noise``.
    progress : bool
        Say each stage's progress on stderr: the least squares, the mode
        search, each phase of the sampler (:mod:`bayescal.core.progress`).
    **sample_kw
        To :func:`bayescal.core.fit.run.fit_spectra` (e.g. ``max_steps``,
        ``misfit_shape``).

    Returns
    -------
    FitState
        A channel set aside for want of coherence is in its
        ``not_estimable``; the reference's self-noise as given in its
        meta's ``reference_noise["input"]``.
    """
    if data.known_noise is not None:
        if ref_noise not in (None, "fixed"):
            raise InputError(f"--ref-noise {ref_noise} and --ref-noise-psd both say how to "
                             "treat the reference's noise: give one")
        ref_noise = "fixed"
    state = fit_spectra(data.fitted, data.ref_vectors, data.sut_vectors, data.families,
                        free=fit_response, priors=sampling_priors(data, priors, fit_response),
                        seed=seed, progress=progress,
                        meta=data.meta, ref_noise=ref_noise, known_noise=data.known_noise,
                        **sample_kw)
    meta = stated_prior(state.meta, priors)
    given = data.meta.get("reference_noise_input")
    if given is not None:
        meta = meta.replace(reference_noise=dict(meta.reference_noise or {}, input=given))
    low = {cid: (f"no coherence with the reference in the band (mean multiple coherence "
                 f"{c:.3f}, needed {MIN_COHERENCE:g})") for cid, c in data.low.items()}
    return state.replace(meta=meta, not_estimable={**state.not_estimable, **low},
                         spectra=data.spectra, sut_inventory=data.sut_inventory)
