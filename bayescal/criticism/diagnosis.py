"""What :func:`.diagnose.diagnose` found (:class:`Diagnosis`): its summary,
``diagnosis.json`` (:data:`SCHEMA`), and its finding in plain words."""
from __future__ import annotations

import numpy as np

from .locate import ALPHA, true_runs
from .moves import moves_sentence
from .search import BIC_KEEP


SCHEMA = "bayescal.diagnose/1"
#: Said with any mismatch left once the reference's noise is modelled: its
#: model is two spectral shapes, and a reference noise of another shape
#: leaves mismatch of its own (the harness's ``equal`` regime, the noise
#: shaped like the ground: 11 of 30 clean pairs, none in ``equal-counts``).
REFERENCE_SHAPE_CAVEAT = (
    "the reference's self-noise is modelled as two spectral shapes (white in ground units, "
    "white in its counts); a reference noise of another shape, one that follows the ground "
    "motion's spectrum for instance, leaves a mismatch like this one: a third co-located "
    "sensor settles it (bayescal noise, then --ref-noise-psd)")
#: The same caveat when the user chose ``--ref-noise equal``.
EQUAL_SHAPE_CAVEAT = (
    "the reference's self-noise is modelled as equal to the SUT's; a reference noise of "
    "another level or shape leaves a mismatch like this one: a third co-located sensor "
    "settles it (bayescal noise, then --ref-noise-psd)")


def reference_shape_caveat(mode):
    """The caveat said with a mismatch left by a fit whose reference-noise
    model is an assumed shape (``estimate`` or ``equal``, whether the user
    or the diagnosis chose it); None for ``quiet`` and ``fixed``."""
    return {"estimate": REFERENCE_SHAPE_CAVEAT, "equal": EQUAL_SHAPE_CAVEAT}.get(mode)


class Diagnosis:
    """Everything :func:`diagnose` found; ``summary()`` is diagnosis.json."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def names(self):
        return [e["name"] for e in self.effects]

    def checks(self):
        """:func:`check_misfits` of this diagnosis."""
        return check_misfits(self)

    def unexplained(self):
        """Sentences for mismatch that remains after the final model, with
        the final model's own check misfit (:meth:`checks`) there and how far
        what the SUT recorded is off the model's prediction."""
        after = self.checks()[1]
        edges = np.asarray(self.band_edges)
        out = []
        for m in self.after["mismatch"]:
            inside = (edges[:-1] >= m["band_hz"][0] * (1 - 1e-9)) & \
                (edges[1:] <= m["band_hz"][1] * (1 + 1e-9))
            worst = float(after[inside].max()) if inside.any() else m["misfit_max"]
            off = (f"; what the SUT recorded is off the model's prediction by up to "
                   f"{100 * m['amplitude_off']:.2g} % in amplitude and {m['phase_off_rad']:.2g} "
                   "rad in phase there" if "amplitude_off" in m else "")
            out.append(f"unexplained mismatch in band {m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g}"
                       f" Hz on channels {', '.join(m['channels'])} (p = {m['p_value']:.2g}; "
                       f"largest standardised misfit there {worst:.3g}, the final model's check"
                       f"{off})")
        return out

    def movements(self):
        """How each channel's orientation (and response) moved from the
        base fit to the final fit (median differences)."""
        b, f = self.base.summary()["channels"], self.final.summary()["channels"]
        out = {}
        for cid in b:
            d = {}
            for key in ("azimuth_deg", "dip_deg"):
                if "median" in b[cid][key] and not b[cid][key].get("undefined"):
                    d[key] = _difference(f[cid][key].get("median"), b[cid][key]["median"])
            for key, v in b[cid].get("response", {}).items():
                d[key] = _difference(f[cid]["response"].get(key, {}).get("median"),
                                     v.get("median"))
            out[cid] = d
        return out

    def sentences(self):
        """The finding in plain words."""
        out = []
        edges = self.band_edges
        ref = self.signatures.get("reference_noise", {})
        if ref.get("kept"):
            out.append(ref["explanation"])
        for e in self.effects:
            s = e["explanation"]
            if e.get("score_gain") is not None and "BIC" not in s:
                s += f" (BIC gain {e['score_gain']:.0f})"
            out.append(s)
        before, after = self.checks()
        fixed = self.before["flag"].any(axis=1) & ~self.after["flag"].any(axis=1)
        if fixed.any() and any(e.get("score_gain") for e in self.effects):
            where = ", ".join(f"{edges[a]:.3g}-{edges[b]:.3g}" for a, b in true_runs(fixed))
            out.append(f"modelling {'it' if len(self.effects) == 1 else 'them'} removes the "
                       f"misfit in {where} Hz (largest standardised misfit there "
                       f"{before[fixed].max():.3g} -> {after[fixed].max():.3g}, each model's "
                       "check)")
        if any(e.get("score_gain") for e in self.effects) and self.final is not self.base:
            out.append(misfit_change(edges, before, after))
        if any(e.get("score_gain") for e in self.effects) and self.final is not self.base:
            moved = moves_sentence(self.base.summary(), self.final.summary())
            if moved:
                out.append(moved)
        if not self.effects and not self.after["mismatch"]:
            out.append("no mismatch: the model describes the recordings within their noise"
                       + (" once the reference's noise is modelled" if ref.get("kept") else ""))
        out += self.unexplained()
        caveat = reference_shape_caveat((self.final.meta.reference_noise or {}).get("mode"))
        if caveat and self.after["mismatch"]:
            out.append(caveat)
        return out

    def summary(self):
        def cells(loc):
            return {"misfit": loc["misfit"], "p_value": loc["p_value"]}
        steps = [[{k: v for k, v in t.items()} for t in step] for step in self.steps]
        return {"schema": SCHEMA, "mismatch": self.before["mismatch"],
                "effects": self.effects, "unexplained": self.after["mismatch"],
                "summary": self.sentences(),
                "per_band": {"band_edges_hz": self.band_edges, "channels": self.ids,
                             "before": cells(self.before), "after": cells(self.after),
                             "before_under_final_noise": cells(self.before_common),
                             "check_before": {"misfit": self.checks()[0]},
                             "check_after": {"misfit": self.checks()[1]},
                             "ratio_amplitude_before": np.abs(self.ratio_before),
                             "ratio_phase_deg_before": np.degrees(np.angle(self.ratio_before)),
                             "ratio_amplitude_after": np.abs(self.ratio_after),
                             "ratio_phase_deg_after": np.degrees(np.angle(self.ratio_after))},
                "signatures": self.signatures, "search": steps,
                "movements": self.movements(),
                "criteria": {"alpha_familywise": ALPHA, "bic_keep": BIC_KEEP,
                             "score": "BIC difference under the extended model's noise model"},
                "base": self.base.summary(), "final": self.final.summary()}


def check_misfits(d):
    """``(before, after)``: the (B, n_u) standardised misfit per band and
    SUT channel of the fit's and of the final model's own model check in
    the diagnosis ``d`` (each at its posterior median under its own noise
    model, as result.json's ``adequacy`` and the console's check give it),
    the one misfit its sentences and page quote; the search's
    (:func:`.locate.locate`) for a fit that kept none (one read back from
    diagnosis.json)."""
    saved = getattr(d, "saved_checks", None)
    if saved is not None:
        return saved

    def of(fit, fallback):
        m = (getattr(fit, "diagnostics", None) or {}).get("band_misfit")
        return np.asarray(fallback if m is None else m, float).reshape(np.shape(fallback))
    before = d.before.get("misfit")
    return (of(d.base, d.before_common["misfit"] if before is None else before),
            of(d.final, d.after["misfit"]))


def _difference(a, b):
    """a - b, or nan when either is missing (a summary holds None for nan)."""
    return float("nan") if a is None or b is None else a - b


def misfit_change(edges, before, after):
    """One sentence on how the standardised misfit over the whole band moved
    (median and largest), with the verb the numbers call for."""
    mb, ma = float(np.median(before)), float(np.median(after))
    verb = "falls" if ma < mb else "rises" if ma > mb else "stays"
    return (f"over the whole {edges[0]:.3g}-{edges[-1]:.3g} Hz band the standardised misfit "
            f"{verb} from median {mb:.3g} (largest {np.max(before):.3g}) to median {ma:.3g} "
            f"(largest {np.max(after):.3g}), each model's check; 1 means a fit within the noise")


class SavedFit:
    """A fit as ``diagnosis.json`` holds it (its ``result.json`` content):
    :meth:`summary` and ``convergence`` (a
    :class:`~bayescal.result.convergence.Convergence` of the slowest
    parameter's figures: the smallest ESS, the largest tau and R-hat)."""

    def __init__(self, summary):
        from ..result.convergence import Convergence

        self.saved = summary
        c = summary.get("convergence", {})
        self.convergence = Convergence(
            tau=np.array([c.get("tau_max")], float), ess=np.array([c.get("ess_min")], float),
            rhat=np.array([c.get("rhat_max")], float), acceptance=c.get("acceptance"),
            n_steps=c.get("n_steps", 0), n_walkers=c.get("n_walkers", 0), burn=0,
            converged=c.get("converged", True))

    def summary(self):
        return self.saved


class SavedDiagnosis(Diagnosis):
    """A :class:`Diagnosis` read back from its summary (``diagnosis.json``):
    everything the diagnosis page reads (:mod:`bayescal.report.diagnosis`),
    without the models or the spectra. Its sentences and summary are the
    saved ones; ``final`` is ``base`` when the two saved fits are one (no
    effect modelled)."""

    def __init__(self, summary):
        pb = summary["per_band"]

        def cells(key, mismatch):
            return {"misfit": np.asarray(pb[key]["misfit"], float),
                    "p_value": np.asarray(pb[key]["p_value"], float), "mismatch": mismatch}

        def ratio(when):
            return np.asarray(pb[f"ratio_amplitude_{when}"], float) * np.exp(
                1j * np.radians(np.asarray(pb[f"ratio_phase_deg_{when}"], float)))

        base = SavedFit(summary["base"])
        super().__init__(
            base=base, final=base if summary["final"] == summary["base"] else
            SavedFit(summary["final"]), before=cells("before", summary["mismatch"]),
            after=cells("after", summary["unexplained"]),
            before_common=cells("before_under_final_noise", []), effects=summary["effects"],
            band_edges=np.asarray(pb["band_edges_hz"], float), ids=list(pb["channels"]),
            ratio_before=ratio("before"), ratio_after=ratio("after"),
            signatures=summary["signatures"], steps=summary["search"])
        self.saved = summary
        if "check_before" in pb:        # each model's own check, as the live page draws it
            self.saved_checks = (np.asarray(pb["check_before"]["misfit"], float),
                                 np.asarray(pb["check_after"]["misfit"], float))

    def sentences(self):
        return list(self.saved["summary"])

    def summary(self):
        return self.saved
