"""MCMC coverage of the errors-in-variables fits over regimes of the
reference's self-noise (``validation/studies/eiv_study.py --mcmc`` runs this).

Each pair: 1 h at 10 Hz, band 0.02-1 Hz, self-noise white in counts (SUT 30 s,
reference 120 s nominal responses), SUT at a random azimuth with horizontals
about 90 degrees apart, dips and the vertical's tilt about 1 degree, gains off
their metadata by up to 3 % (uniform), period and damping off by up to 5 %
when fitted. A regime is the reference/SUT noise-power ratio (0, 1, 10) and
the coherence between the two sensors, ``c_u c_r`` (0.9, 0.99, 0.999); each
pair is fitted exactly as ``bayescal fit`` does (``bayescal.calibrate``:
closed-form start, least squares, emcee to the convergence rule) with
``--fit-response gain`` (angle+gain, each SUT gain free) or ``all`` (joint).
Checks per parameter kind: standardised error ``(median - truth) / sd`` and
whether the truth is inside the central 68 % and 90 % intervals.
"""
from __future__ import annotations

import time

import numpy as np

from bayescal.pair.workflow import calibrate
from bayescal.simulate import simulate_pair
# NOMINAL and coherences are the studies' built on this one (ec.NOMINAL, ...)
from bayescal.simulate.harness import NOMINAL, coherences, draw_truth  # noqa: F401
from bayescal.simulate.coverage import binomial_band, coverage_checks

KINDS = ("azimuth", "dip", "tilt_north", "tilt_east", "gain", "period", "damping")


def run_pair(seed, ratio, pair_coherence, fit, mode, duration=3600.0, fs=10.0,
             noise_in_counts=True):
    """One seeded pair fitted by MCMC: a dict of checks, convergence and time.
    ``noise_in_counts=False``: each channel's self-noise a fixed share of its
    own signal (the simulator's default; outside mode ``estimate``'s model),
    recorded as ``noise: "signal"``."""
    azs, dips, resp = draw_truth(seed, fit)
    cu, cr = coherences(pair_coherence, ratio)
    sim = simulate_pair(duration=duration, fs=fs, seed=seed, coherence=cu, ref_coherence=cr,
                        sut_azimuth=azs, sut_dip=dips, sut_response=resp,
                        nominal_response=NOMINAL, noise_in_counts=noise_in_counts)
    t0 = time.process_time()
    post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.02, 1.0),
                     fit_response=fit, seed=seed, progress=False, ref_noise=mode)
    cpu = time.process_time() - t0
    c90 = coverage_checks(post, azs, dips, resp, level=90.0)
    c68 = coverage_checks(post, azs, dips, resp, level=68.0)
    conv = post.convergence
    return {"seed": seed, "ratio": ratio, "pair_coherence": pair_coherence, "fit": fit,
            "mode": mode, "noise": "counts" if noise_in_counts else "signal",
            "duration_s": duration, "sut_coherence": cu, "ref_coherence": cr, "cpu_s": cpu,
            "converged": bool(conv.converged), "ess_min": conv.ess_min,
            "rhat_max": float(np.max(conv.rhat)),
            "checks": {k: {"z": c90[k][1], "in90": c90[k][0], "in68": c68[k][0]} for k in c90}}


#: Row fields added after the first rows were written, and their value then.
LATER_FIELDS = {"noise": "counts", "duration_s": 3600.0}


def summarise(rows, by=("fit", "noise", "duration_s", "mode", "ratio")):
    """Per regime (``by``) and parameter kind: mean and sd of z, counts inside
    the 68 % and 90 % intervals with their 99 % binomial bands."""
    groups = {}
    for r in rows:
        key = tuple(r.get(k, LATER_FIELDS.get(k)) for k in by)
        for name, c in r["checks"].items():
            kind = name.split(":")[1]
            groups.setdefault(key, {}).setdefault(kind, []).append(c)
    out = []
    for key in sorted(groups):
        for kind in KINDS:
            vals = groups[key].get(kind)
            if not vals:
                continue
            z = np.array([v["z"] for v in vals])
            n = len(vals)
            k68, k90 = sum(v["in68"] for v in vals), sum(v["in90"] for v in vals)
            b68, b90 = binomial_band(n, 0.68), binomial_band(n, 0.9)
            out.append(dict(zip(by, key), kind=kind, n=n, z_mean=float(z.mean()),
                            z_sd=float(z.std(ddof=1)) if n > 1 else float("nan"),
                            in68=int(k68), band68=list(b68), in90=int(k90), band90=list(b90),
                            ok=bool(b68[0] <= k68 <= b68[1] and b90[0] <= k90 <= b90[1])))
    return out


def table(summary):
    """Markdown table of :func:`summarise`'s rows."""
    lines = ["| fit | self-noise | record | ref noise | ratio | kind | n | z mean | z sd "
             "| in 68 % [99 % band] | in 90 % [99 % band] | |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['fit']} | {s['noise']} | {s['duration_s'] / 3600:g} h | {s['mode']} | "
                     f"{s['ratio']:g} | {s['kind']} | {s['n']} | "
                     f"{s['z_mean']:+.2f} | {s['z_sd']:.2f} | {s['in68']} {s['band68']} | "
                     f"{s['in90']} {s['band90']} | {'ok' if s['ok'] else 'OUT'} |")
    return "\n".join(lines)
