"""Is the reference's own self-noise part of the mismatch? (the first step of
:func:`.diagnose.diagnose`, before any physics is named).

The base model (``--ref-noise quiet``) assumes a reference much quieter than
the SUT. When the reference is as noisy as the SUT (a huddle of two sensors
of one class), its noise biases the regression ``S_ur S_rr^-1`` toward zero
by the reference's coherence deficit, which changes from band to band with
the reference's signal-to-noise ratio: the base model misfits, and the
catalogue's effects (a pole, a delay, a gain error) absorb that misfit and
are named as physics that is not there. The reference's noise is a noise-model
term, not physics: this module tests for it and, when present, the
diagnosis criticises the model that includes it.

Test: the errors-in-variables model of :mod:`bayescal.core.model.eiv` in mode
``estimate`` (the reference's noise a combination of two spectral shapes per
reference channel, white in ground units and white in its counts, profiled
out) nests the quiet model at zero noise coefficients. Both are scored under
the errors-in-variables model's noise model (the quiet model re-optimised
under it), as the catalogue's effects are (:func:`.search.score`):

    dBIC = 2 (log L_eiv - log L_quiet) - 2 n_r ln n,   n = 2 B n_u n_r.
"""
from __future__ import annotations

import numpy as np

from ..core.model import as_real, EIVModel, Model
from ..core.fit import least_squares_fit


class _QuietUnderEIV(EIVModel):
    """The errors-in-variables statistic with the reference's noise held at
    zero: the quiet model's residual, judged under an EIV noise model."""

    def _estimate_statistic(self, theta, w):
        theta = np.atleast_2d(theta)
        vecs, ratio = self.unpack(theta)
        x0 = as_real(self.plain_residual_blocks(vecs, ratio, theta)[:, 0])
        f = self._row_factor(ratio)
        if f is not None:
            x0 = x0 * f
        return x0, np.zeros((theta.shape[0], self.spectra.n_r, 2))


def applicable(model):
    """The test needs a quiet base model (not already errors-in-variables,
    no effects) and two or more reference channels (their cross-spectra
    separate the ground motion from the reference's noise; with one channel
    a side it is not identifiable). One SUT channel is enough: the coherence
    gate leaves one when both sensors are noisy and only one SUT channel sees
    the ground above the noise."""
    sp = model.spectra
    return (type(model) is Model and not model.effects and not model.per_block
            and sp.n_r >= 2)


def reference_noise_test(model, theta, bic_keep=10.0):
    """Score the reference's self-noise against the quiet ``model`` at its
    least-squares point ``theta``.

    Returns ``(result, eiv_model, eiv_theta, eiv_cov)``: ``result`` a
    JSON-safe dict (``applicable``, ``delta_bic``, ``delta_loglik``,
    ``n_extra_params``, ``kept``, ``noise_to_signal`` per reference channel,
    median over bands, ``explanation``); the model items are None unless kept.
    """
    if not applicable(model):
        return ({"applicable": False, "kept": False, "delta_bic": None,
                 "explanation": "reference noise not tested (one reference channel, or the "
                                "base model already models it)"}, None, None, None)
    sp = model.spectra
    eiv = EIVModel(sp, model.ref_vectors, model.blocks, model.priors, ref_noise="estimate")
    eiv.inflation_floor = model.inflation_floor
    try:
        th_e, cov_e = least_squares_fit(eiv, theta)
    except Exception as exc:     # noqa: BLE001 - a failed fit is no evidence
        return ({"applicable": True, "kept": False, "delta_bic": None,
                 "explanation": f"reference noise not scored (its fit failed: {exc})"},
                None, None, None)
    quiet = _QuietUnderEIV(sp, model.ref_vectors, model.blocks, model.priors, ref_noise="estimate")
    quiet.adopt_noise(eiv.noise)
    from .search import best_refit
    ll_q = best_refit(quiet, (np.asarray(theta, float), th_e))[0]
    ll_e = float(eiv.log_likelihood(th_e)[0])
    n = 2 * sp.n_bands * sp.n_u * sp.n_r
    k = 2 * sp.n_r
    dbic = 2.0 * (ll_e - ll_q) - k * np.log(n)
    kept = bool(dbic > bic_keep)
    psd = eiv.reference_noise_psd(th_e)[0] if kept else None      # (B, n_r)
    out = {"applicable": True, "kept": kept, "delta_bic": float(dbic),
           "delta_loglik": float(ll_e - ll_q), "n_extra_params": int(k), "n_data": int(n)}
    if kept:
        srr = np.real(np.einsum("bkk->bk", sp.band_sums()[:, sp.n_u:, sp.n_u:]))
        srr = srr / (sp.bins_per_band * sp.n_segments)[:, None] * sp.psd_scale
        nsr = np.median(np.clip(psd, 0, None) / np.maximum(srr - np.clip(psd, 0, None),
                                                           1e-30 * srr), axis=0)
        out["noise_to_signal"] = {c: float(v) for c, v in zip(sp.ref_ids or range(sp.n_r), nsr)}
        out["explanation"] = (
            f"the reference's own self-noise is not negligible (BIC gain {dbic:.0f} for "
            f"modelling it, median noise-to-signal ratio "
            + ", ".join(f"{v:.2g}" for v in nsr) + "): the diagnosis judges every effect "
            "against the model with the reference's noise (as --ref-noise estimate); it is "
            "noise, not a response error")
        return out, eiv, th_e, cov_e
    out["explanation"] = (f"the reference's self-noise is negligible (BIC gain {dbic:.1f} "
                          f"<= {bic_keep:g} for modelling it)")
    return out, None, None, None
