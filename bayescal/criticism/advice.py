"""What the criticism advises, and only advice that leads somewhere.

* Every option an advice names (``--band FMIN FMAX``, ``--fit-response
  all``, ``--diagnose-budget S``: :data:`ARITY`) is checked against the rule
  the fit itself applies to this run (:func:`refusal`: the spectra's
  :func:`bayescal.core.spectra.band_refusal` and the fit's
  :func:`bayescal.core.fit.response_fit_refusal`, which ``bayescal fit``
  raises on); an advice the run would refuse is not given.
* A narrower band (:func:`band`) is advised only when the mismatch lies at
  the band's edges (the model holds on one run of bands between them), the
  narrower band keeps at least :data:`MIN_INFORMATION` of the fit's
  information, and the band was chosen from the data: a band given with
  ``--band`` (as the criticism advised it, perhaps) is not narrowed again,
  for a mismatch that follows the band's edge would follow it again.
  Otherwise the verdict says the mismatch is unexplained inside the band.
"""
from __future__ import annotations

import math
import re

import numpy as np

from .locate import ratio_weights, true_runs

#: The options an advice may name and how many values each takes (an
#: option named with none, such as ``--ref`` in "the order of --ref and
#: --sut", is mentioned, not advised).
ARITY = {"--band": 2, "--fit-response": 1, "--diagnose-budget": 1}
#: The least share of the fit's information (the inverse variance of the
#: recorded/predicted ratio, summed over the bands kept:
#: :func:`bayescal.criticism.locate.ratio_weights`) a narrower band must
#: keep to be advised: its intervals widen by at most a factor of 2.
MIN_INFORMATION = 0.25


def options(text):
    """The options ``text`` advises, as ``[(option, [values])]``: each of
    :data:`ARITY` with its values (an option named without its values is
    not advised and left out)."""
    out = []
    for m in re.finditer(r"(--[a-z][a-z-]*)((?:\s+[^\s(;,]+)*)", text):
        flag, n = m.group(1), ARITY.get(m.group(1), 0)
        values = m.group(2).split()[:n]
        if n and len(values) == n:
            out.append((flag, values))
    return out


def refusal(text, model):
    """Why the run of ``model`` (its spectra and response families) would
    refuse an option ``text`` advises, or None when it accepts every one."""
    from ..core.fit import response_fit_refusal
    from ..core.spectra import band_refusal

    for flag, values in options(text):
        if flag == "--fit-response":
            why = response_fit_refusal([b.family for b in model.blocks], values[0])
        elif flag == "--band":
            try:
                why = band_refusal([float(v) for v in values], model.spectra.fs)
            except ValueError:
                why = f"--band {' '.join(values)} is not two numbers"
        else:
            why = None
        if why:
            return why
    return None


def accepted(advice, model):
    """``advice`` (a list of texts) without those the run of ``model``
    would refuse (:func:`refusal`), each once."""
    if model is None:
        return list(dict.fromkeys(advice))
    return [a for a in dict.fromkeys(advice) if a and refusal(a, model) is None]


def _edge_band(edges, flag, weights):
    """``((lo, hi), None)``: the run of bands where the model holds when the
    mismatch (``flag``, (B, n_u)) lies only at the band's edges and the run
    keeps :data:`MIN_INFORMATION` of ``weights``; else ``(None, why not)``."""
    bad = flag.any(axis=1)
    if not bad.any():
        return None, "no band misfits"
    if bad.all():
        return None, "the model misfits in every band"
    runs = true_runs(bad)
    if any(a > 0 and b < bad.size for a, b in runs):
        return None, "the mismatch lies inside the band, not only at its edges"
    (a, b), = true_runs(~bad)
    share = weights[a:b].sum() / weights.sum()
    if share < MIN_INFORMATION:
        return None, (f"the bands where the model holds ({edges[a]:.3g}-{edges[b]:.3g} Hz) "
                      f"keep {100 * share:.0f} % of the fit's information")
    return (float(edges[a]), float(edges[b])), None


def _inward(lo, hi):
    """``lo`` rounded up and ``hi`` down to 3 significant digits: a band
    inside the one found."""
    def digits(x):
        return 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.ceil(lo / digits(lo) - 1e-9) * digits(lo), \
        math.floor(hi / digits(hi) + 1e-9) * digits(hi)


def band(d, *, band_given, weights=None):
    """``(advice, why not)``: a ``--band`` advice for the diagnosis ``d``
    when a narrower band leads somewhere (module docstring), else ``(None,
    the reason)``. The mismatch is read under the improved model, then (when
    that gives no band) under the fit's. ``weights``: the information per
    band (default: :func:`bayescal.criticism.locate.ratio_weights` of the
    fit's spectra, summed over channels)."""
    edges = np.asarray(d.band_edges)
    if band_given:
        return None, ("the band was given with --band: a narrower one is not advised, as a "
                      "mismatch that follows the band's edge follows a narrower band's too")
    if weights is None:
        weights = ratio_weights(d.base.model.spectra).sum(axis=1)
    weights = np.asarray(weights, float)
    why = None
    for flag in (d.after["flag"], d.before["flag"]):
        good, why_here = _edge_band(edges, np.asarray(flag), weights)
        if good:
            lo, hi = _inward(*good)
            return (f"--band {lo:.3g} {hi:.3g} (the band where the model holds, "
                    "the mismatch at its edges left out) if the misfit is not physics to "
                    "model"), None
        why = why or why_here
    return None, why
