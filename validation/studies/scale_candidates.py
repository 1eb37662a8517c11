"""Forms of the misfit scale on the ten-minute COWI windows, by
importance reweighting of one set of fits.

``short_windows.py`` refits the 102 windows for each form of the noise
scale. The forms differ only in the likelihood's band term (the noise model
is fixed before sampling, :mod:`bayescal.core.model.misfit_scale`), so the
posterior under a form ``f`` is the default's posterior reweighted by
``exp(loglik_f - loglik_default)`` at each draw, from the draws' band
energies ``q``. Here every window (and the whole record) is fitted once with
the default, and each form's windows are summarised exactly as
``short_windows.py`` does (weighted quantiles for the medians and
intervals; the whole record's value reweighted too). Each form's smallest
effective-sample fraction (Kish) is stored beside it. A form's
reweighted summary agrees with its own refitted run to Monte Carlo error:
``check`` compares the stored runs of ``short_windows.py`` (``--recheck``:
that comparison alone, on the stored result).

Forms: the scale per band, free (the default) or with ``s_b >= 1``, or with
another shape; the pooled scale with each band its own with probability
``pi`` (``s >= 1`` or free); the Gaussian; and a scale per band whose
variance factor may not fall below ``f0`` (``FACTOR_FLOOR``: the
likelihood's slope in ``q_b`` is ``min(1 / f0, (a + k_b) / (a + q_b))``, the
marginal's where a band's residual exceeds ``f0 (a + k_b) - a``, a Gaussian
of variance ``f0`` below), with the default shape or another. The same
forms per SUT channel (:mod:`bayescal.core.model.channel_scale`: each
channel's share of the bands' energies), and the Gaussian with a fixed
variance factor per channel. Beside the forms, per channel: the room a
constant factor has (:func:`channel_room`) and how the default's window
estimates stray from the whole record's (:func:`wander`).

    python validation/studies/scale_candidates.py --out validation/results/repeatability/scale_candidates.json
    python validation/studies/scale_candidates.py --seed-offset 1000 \
        --out validation/results/repeatability/scale_candidates_seeds1000.json
    python validation/studies/scale_candidates.py --recheck   # after a refitted run is stored
"""
from __future__ import annotations

import argparse
import json
import pickle
import shlex
import sys
import warnings
from pathlib import Path

import numpy as np
import short_windows as sw                    # the sibling module, run as a script
import study_results

from bayescal.core.model import channel_scale, misfit_scale

ROOT = Path(__file__).resolve().parents[2]
SHAPE = misfit_scale.MISFIT_SHAPE


def _settings(pi, floor, a=SHAPE, factor_floor=0.0, per_channel=False):
    """The module's likelihood with ``OWN_SCALE_PROB = pi``, ``SCALE_FLOOR =
    floor`` and, for the scale per band, its least variance factor
    ``factor_floor`` (:data:`~bayescal.core.model.misfit_scale.FACTOR_FLOOR`),
    of a fit's draws (:func:`short_windows.posterior_draws`): the bands'
    energies, or with ``per_channel`` each SUT channel's shares of them
    (:mod:`bayescal.core.model.channel_scale`)."""
    def loglik(d):
        old = misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR
        misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR = pi, floor
        try:
            if per_channel:
                return channel_scale.channel_loglik(d["qc"], d["kc"], a, d["weight"],
                                                    floor=factor_floor)
            return misfit_scale.band_loglik(d["q"], d["k"], a, d["weight"], floor=factor_floor)
        finally:
            misfit_scale.OWN_SCALE_PROB, misfit_scale.SCALE_FLOOR = old
    return loglik


def _fitted(d):
    """The likelihood the fits sampled: the module's defaults."""
    return misfit_scale.band_loglik(d["q"], d["k"], SHAPE, d["weight"])


def fixed_factors(f_north, f_east):
    """The Gaussian with each channel's noise variance times a fixed factor
    (its shares of every band divided by it): a widening per channel set
    from outside the window's data."""
    f = np.array([f_north, f_east])

    def loglik(d):
        return -np.sum(d["weight"][:, None] * d["qc"] / f, axis=(1, 2))
    return loglik


#: label -> log likelihood of a fit's draws
FORMS = {
    "per band, free (default)": _settings(1.0, False),
    "Gaussian": lambda d: -np.sum(d["weight"] * d["q"], axis=1),
    "per band, s >= 1": _settings(1.0, True),
    "per band, free, a = 3": _settings(1.0, False, 3.0),
    "per band, factor >= 1": _settings(1.0, False, factor_floor=1.0),
    "per band, factor >= 0.9": _settings(1.0, False, factor_floor=0.9),
    "per band, factor >= 0.8": _settings(1.0, False, factor_floor=0.8),
    "per band, factor >= 1, a = 2.5": _settings(1.0, False, 2.5, 1.0),
    "per band, factor >= 1, a = 3": _settings(1.0, False, 3.0, 1.0),
    "per band, factor >= 0.9, a = 3": _settings(1.0, False, 3.0, 0.9),
    "per band, factor >= 1, a = 4": _settings(1.0, False, 4.0, 1.0),
    "pooled alone (pi = 0), s >= 1": _settings(0.0, True),
    "pooled alone (pi = 0), free": _settings(0.0, False),
    "pooled, pi = 0.1, s >= 1": _settings(0.1, True),
    "pooled, pi = 0.25, s >= 1": _settings(0.25, True),
    "pooled, pi = 0.5, s >= 1": _settings(0.5, True),
    "pooled, pi = 0.25, free": _settings(0.25, False),
    "pooled, pi = 0.5, free": _settings(0.5, False),
}
#: The same forms with a scale per SUT channel (its shares of each band).
CHANNEL_FORMS = {
    "per channel and band, free": _settings(1.0, False, per_channel=True),
    "per channel and band, free, a = 3": _settings(1.0, False, 3.0, per_channel=True),
    "per channel and band, free, a = 4": _settings(1.0, False, 4.0, per_channel=True),
    "per channel and band, s >= 1": _settings(1.0, True, per_channel=True),
    "per channel and band, factor >= 1": _settings(1.0, False, factor_floor=1.0,
                                                   per_channel=True),
    "per channel and band, factor >= 1, a = 3": _settings(1.0, False, 3.0, 1.0, True),
    "per channel and band, factor >= 1, a = 4": _settings(1.0, False, 4.0, 1.0, True),
    "per channel and band, factor >= 0.9, a = 3": _settings(1.0, False, 3.0, 0.9, True),
    "per channel, pooled (pi = 0), free": _settings(0.0, False, per_channel=True),
    "per channel, pooled (pi = 0), s >= 1": _settings(0.0, True, per_channel=True),
    "per channel, pooled (pi = 0), s >= 1, a = 1": _settings(0.0, True, 1.0, per_channel=True),
    "per channel, pooled (pi = 0), s >= 1, a = 2.5": _settings(0.0, True, 2.5, per_channel=True),
    "per channel, pooled (pi = 0), s >= 1, a = 3": _settings(0.0, True, 3.0, per_channel=True),
    "per channel, pooled, pi = 0.1, s >= 1": _settings(0.1, True, per_channel=True),
    "per channel, pooled, pi = 0.25, s >= 1": _settings(0.25, True, per_channel=True),
    "per channel, pooled, pi = 0.5, s >= 1": _settings(0.5, True, per_channel=True),
    "per channel, pooled, pi = 0.25, free": _settings(0.25, False, per_channel=True),
    "per channel, pooled, pi = 0.5, free": _settings(0.5, False, per_channel=True),
    "per channel, pooled, pi = 0.25, s >= 1, a = 3": _settings(0.25, True, 3.0,
                                                               per_channel=True),
    "per channel, Gaussian, fixed factors 1.6 (N), 2.2 (E)": fixed_factors(1.6, 2.2),
    "per channel, Gaussian, fixed factors 1.5 (N), 2.0 (E)": fixed_factors(1.5, 2.0),
}


def weighted_quantiles(x, w, probs):
    """Quantiles ``probs`` of draws ``x`` with normalised weights ``w``."""
    i = np.argsort(x)
    c = (np.cumsum(w[i]) - 0.5 * w[i]) / np.sum(w)
    return np.interp(probs, c, x[i])


def reweighted(draws, form):
    """``(azimuth summaries per channel, Kish fraction)`` of one fit's
    draws under ``form``: median, 68 and 95 % intervals, sd from the 68 %."""
    log_w = form(draws) - _fitted(draws)
    w = np.exp(log_w - np.max(log_w))
    w /= w.sum()
    out = {}
    for j, c in enumerate(("LHN", "LHE")):
        p = weighted_quantiles(draws["az"][:, j], w, [0.025, 0.16, 0.5, 0.84, 0.975])
        out[c] = {"median": float(p[2]), "ci95": [float(p[0]), float(p[4])],
                  "sd68": float(p[3] - p[1]) / 2}
    return out, float(1.0 / (w.size * np.sum(w ** 2)))


def evaluate(fits, whole_draws, form):
    """One form's summary over the windows (``short_windows.channel_summary``)."""
    whole, _ = reweighted(whole_draws, form)
    ok, kish = [], []
    for row, draws in fits:
        est, frac = reweighted(draws, form)
        kish.append(frac)
        ok.append({c: {**est[c], "bound_sd": row[c]["bound_sd"],
                       "bound_width95": row[c]["bound_width95"]} for c in ("LHN", "LHE")})
    out = {c: sw.channel_summary(ok, c, whole[c]["median"]) for c in ("LHN", "LHE")}
    out["min_kish_fraction"] = float(np.min(kish))
    out["whole_record"] = {c: whole[c]["median"] for c in ("LHN", "LHE")}
    return out


def channel_room(fits, whole_draws):
    """Per channel, the room a constant widening has, from the Gaussian's
    windows (reweighted; a width scales as the square root of its channel's
    variance factor): the least factor that keeps every window at or above
    its bound, ``(1 / min width/bound)^2``, and the most the scatter allows,
    ``(1.1 scatter/bound / median width/bound)^2``; beside them the
    channel's excess residual energy in its windows, the median over windows
    of the posterior median of ``Q_c / K_c`` (weighted sums over the bands)."""
    g = evaluate(fits, whole_draws, FORMS["Gaussian"])
    excess = np.array([np.median(np.sum(d["weight"][:, None] * d["qc"], axis=1)
                                 / np.sum(d["weight"][:, None] * d["kc"], axis=0), axis=0)
                       for _, d in fits])                                   # (windows, 2)
    out = {}
    for j, c in enumerate(("LHN", "LHE")):
        x = g[c]
        out[c] = {"gaussian_width_over_bound_min": x["width_over_bound_min"],
                  "gaussian_width_over_bound_median": x["width_over_bound_median"],
                  "gaussian_scatter_over_bound": x["scatter_over_bound"],
                  "least_factor": x["width_over_bound_min"] ** -2,
                  "most_factor": (1.1 * x["scatter_over_bound"]
                                  / x["width_over_bound_median"]) ** 2,
                  "residual_excess_median": float(np.median(excess[:, j])),
                  "windows_east_excess_above_north": int(np.sum(excess[:, 1] > excess[:, 0]))}
    return out


def wander(fits, whole_draws):
    """Per channel, how the default's window medians stray from the whole
    record's: their errors ``z`` in units of each window's bound, the
    standard deviation of ``z``, its lag-one autocorrelation, the scatter of
    successive differences ``sqrt(mean(diff(z)^2) / 2)`` (the window-to-window
    scatter, blind to a drift slower than a window), and the means of ``z``
    over consecutive two-hour blocks (12 windows)."""
    whole = np.median(whole_draws["az"], axis=0)
    out = {}
    for j, c in enumerate(("LHN", "LHE")):
        med = np.array([np.median(d["az"][:, j]) for _, d in fits])
        z = (med - whole[j]) / np.array([row[c]["bound_sd"] for row, _ in fits])
        zc = z - z.mean()
        out[c] = {"sd": float(np.std(z, ddof=1)),
                  "lag_one_correlation": float(np.sum(zc[1:] * zc[:-1]) / np.sum(zc ** 2)),
                  "successive_difference_scatter": float(np.sqrt(np.mean(np.diff(z) ** 2) / 2)),
                  "two_hour_means": [float(z[i:i + 12].mean()) for i in range(0, z.size, 12)]}
    return out


def fit_all(every, seed_offset=0):
    """The default fit of every ``every``-th window (window k's sampler seed
    ``k + seed_offset``, as ``short_windows.py``) and of the whole record,
    with their draws."""
    from obspy import UTCDateTime
    from bayescal.io import read_waveforms
    data = (read_waveforms(str(sw.COWI / "C100823215422_COWI.LHx")),
            read_waveforms([str(sw.COWI / "DT000110.LH1"), str(sw.COWI / "DT000110.LH2")]))
    t0, t1 = UTCDateTime(sw.START), UTCDateTime(sw.END)
    whole_draws = {}
    sw.whole_record(data, t0, t1, ["drop"], None, whole_draws)
    fits = []
    starts = np.arange(t0.timestamp, t1.timestamp - 1, 600.0)
    for k in range(0, starts.size, every):
        draws = {}
        row = sw.fit_window(data, UTCDateTime(starts[k]), UTCDateTime(starts[k] + 600.0),
                            k + seed_offset, "drop", None, draws)
        fits.append((row, draws))
        print(str(UTCDateTime(starts[k])), flush=True)
    return fits, whole_draws


def check(result, stored):
    """Each refitted run of ``short_windows.py`` in ``stored`` (label ->
    summary file) beside its reweighted form: the numbers the docs quote."""
    keys = ("width_over_bound_median", "scatter_over_bound", "narrower_than_bound",
            "holds_whole_record", "repeatability_ratio")
    out = {}
    for label, path in stored.items():
        run = json.loads(Path(path).read_text())["summary"]["drop"]
        out[label] = {c: {k: [result["forms"][label][c][k], run[c][k]] for k in keys}
                      for c in ("LHN", "LHE")}
    return out


#: The forms refitted by ``short_windows.py``: label -> its stored summary.
REFITTED = {"per band, free (default)": "short_windows.json",
            "per band, s >= 1": "short_windows_floor.json",
            "pooled, pi = 0.1, s >= 1": "short_windows_pooled_0.1.json",
            "pooled, pi = 0.25, s >= 1": "short_windows_pooled.json",
            "per band, factor >= 1, a = 3": "short_windows_factor_floor.json",
            "per channel, pooled (pi = 0), s >= 1, a = 2.5": "short_windows_channel.json"}


def kept_fits(args):
    """:func:`fit_all`, or its draws read back from ``args.draws``."""
    path = None if args.draws is None else Path(args.draws)
    if path is not None and path.exists():
        with path.open("rb") as f:
            return pickle.load(f)
    fits = fit_all(args.every, args.seed_offset)
    if path is not None:
        with path.open("wb") as f:
            pickle.dump(fits, f)
    return fits


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "repeatability"
                                         / "scale_candidates.json"))
    ap.add_argument("--every", type=int, default=1, help="every n-th window only")
    ap.add_argument("--seed-offset", type=int, default=0,
                    help="window k's sampler seed is k plus this (0: k)")
    ap.add_argument("--draws", default=None,
                    help="a file keeping the fits' draws (pickle): read if it exists, else "
                         "written, so that forms can be added without refitting")
    ap.add_argument("--recheck", action="store_true",
                    help="only compare the stored result with the refitted runs stored beside it")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    res = Path(args.out).parent
    if args.recheck:
        result = study_results.read(args.out)
    else:
        fits, whole_draws = kept_fits(args)
        given = sys.argv[1:] if argv is None else argv
        kept = [a for i, a in enumerate(given)             # the cache is not part of the command
                if a != "--draws" and (i == 0 or given[i - 1] != "--draws")]
        result = {"command": " ".join(["python validation/studies/scale_candidates.py"]
                                      + [shlex.quote(a) for a in kept]),
                  "windows": len(fits), "shape_a": SHAPE, "seed_offset": args.seed_offset,
                  "forms": {label: evaluate(fits, whole_draws, form)
                            for label, form in {**FORMS, **CHANNEL_FORMS}.items()},
                  "channel_room": channel_room(fits, whole_draws),
                  "wander": wander(fits, whole_draws)}
    if result["windows"] == 102 and result.get("seed_offset", 0) == 0:   # the refits' seeds
        result["refitted_runs"] = check(result, {label: res / name for label, name
                                                 in REFITTED.items() if (res / name).exists()})
    study_results.write(args.out, result)
    forms = result["forms"]
    for label, f in forms.items():
        print(label, {c: {k: f[c][k] for k in ("width_over_bound_median", "scatter_over_bound",
                                               "width_over_bound_min", "holds_whole_record",
                                               "repeatability_ratio")} for c in ("LHN", "LHE")},
              f["min_kish_fraction"])


if __name__ == "__main__":
    main()
