"""Corrected StationXML from a coil calibration: the channel's stage-1 gain,
long-period pair (``--fit lp``/``all``) and free high-frequency poles and
zeros (``hf``/``all``) replaced by posterior medians with ``plusError`` /
``minusError`` from the 68 % interval; the normalization factor rescaled so
the gain keeps its meaning at the normalization frequency; the overall
sensitivity recalculated; a comment says where the values come from. A
period or damping the prior sets (:mod:`bayescal.core.response.pendulum`) keeps its
nominal value, except that when the data fix damping/period the damping
carries it (:func:`bayescal.io.stationxml.written_period_damping`).
Everything else is left untouched."""
from __future__ import annotations

import copy

import numpy as np
from obspy.core.util.obspy_types import ComplexWithUncertainties

from ..atomic import atomic_path
from ..io.stationxml import find_channel, pole_with_errors, prior_text, update_response


def _replace_hf(stage, spec, roots):
    """Write the free poles/zeros (samples ``roots`` (N, K) rad/s) into ``stage``."""
    scale = 1.0 / (2 * np.pi) if "HERTZ" in str(stage.pz_transfer_function_type).upper() else 1.0
    med = np.median(roots.real, axis=0) + 1j * np.median(roots.imag, axis=0)
    sn = np.array([2j * np.pi * spec.family.norm_freq])
    phi = spec.free_factors(sn, med[None])[0, 0]
    for k, it in enumerate(spec.items):
        target = stage.poles if it.kind == "pole" else stage.zeros
        err = pole_with_errors(roots[:, k])
        for idx, sign in ((it.index, 1), (it.conj_index, -1)):
            if idx < 0:
                continue
            v = complex(med[k].real, sign * med[k].imag)
            lo, up = err.lower_uncertainty, err.upper_uncertainty
            target[idx] = ComplexWithUncertainties(v * scale, lower_uncertainty=lo * scale,
                                                   upper_uncertainty=up * scale)
    # A0 = 1 / |PZ(s_n)|: the free factors multiply PZ(s_n) by 1 / phi(s_n)
    stage.normalization_factor = float(stage.normalization_factor * abs(phi))


def corrected_cal_inventory(inventory, fits):
    """A copy of ``inventory`` with each :class:`CalFit` in ``fits`` written in."""
    inv = copy.deepcopy(inventory)
    for fit in fits:
        ch = find_channel(inv, fit.channel, None)
        phys = fit.physical()
        summary = fit.summary()["parameters"]
        if fit.spec.items:
            _replace_hf(ch.response.response_stages[0], fit.spec, phys["hf"])
        if fit.spec.has_lp:
            samples = np.column_stack([phys["period_s"], phys["damping"], phys["gain"]])
            update_response(ch, samples, "all", summary)
        else:
            update_response(ch, None, "gain", summary)
        ch.comments.append(_comment(fit, summary))
    return inv


def _comment(fit, params):
    """Where the written values come from, and what the prior sets."""
    from obspy import UTCDateTime
    from obspy.core.inventory.util import Comment

    from ..version import __version__

    lo, hi = fit.band_hz
    nominal = {"period_s": fit.spec.family.period_s, "damping": fit.spec.family.damping}
    return Comment(f"Response fitted by bayescal {__version__} on "
                   f"{UTCDateTime.now().strftime('%Y-%m-%d')} from the {fit.kind} coil "
                   f"calibration {fit.meta.get('source', '')}, band {lo:.4g}-{hi:.4g} Hz; "
                   "plusError/minusError are 68 % credible intervals (16-84 % quantiles)."
                   + prior_text(params, nominal))


def write_corrected_cal(inventory, fits, path):
    """Write :func:`corrected_cal_inventory` to ``path`` atomically."""
    inv = corrected_cal_inventory(inventory, fits)
    with atomic_path(path) as tmp:
        inv.write(tmp, format="STATIONXML", validate=False)
    return path
