"""Response-parameter z at the least-squares point, no sampling: a fast probe
of the coverage study (docs/validation/damping_coverage.md).

For each seed of ``validation/studies/coverage_study.py`` (same cases, same spectra)
the fit stops after the least-squares step (the pendulum prior's rows
included); ``z = (theta_ls - truth) / sd`` with ``sd`` the Laplace standard
deviation, for log period, damping and log gain of each channel (carried
from the pendulum's coordinates by the delta method). With the Gaussian likelihood the
posterior is this Laplace approximation to a few hundredths of an sd, so a
``z`` sd above 1 here is in the likelihood, not in the sampler or in the
per-band noise scale. About 1.5-2.5 s per seed (sampling: 4-6 s).

    python validation/studies/laplace_coverage.py --seeds 0 100 --out /tmp/ls_base.json
    python validation/studies/laplace_coverage.py --seeds 0 100 --variant norescale
    python validation/studies/laplace_coverage.py --case 15 --coherence 0.9 --seeds 1000 1060
    (variants, combinable with '+': quiet, norescale, nodes<N>, bpd<N>m<M>, shrink<X>,
    nperseg<N>; norescale acts on the quiet model only: use quiet+norescale)
"""
from __future__ import annotations

import argparse
import functools
import json

import numpy as np
import study_results                          # the sibling module, run as a script


class _Stop(Exception):
    pass


def apply_variant(variant):
    """Monkeypatches for one probe; returns extra ``calibrate`` keywords."""
    import bayescal.core.model.likelihood as lk
    import bayescal.core.model.noisescale as ns
    import bayescal.pair.preparation as pl
    kw = {}
    for v in filter(None, variant.split("+")):
        if v == "norescale":                       # no SUT-counts row rescaling (quiet model)
            ns.rescale_rows = lambda r, *a, **k: r
        elif v.startswith("nodes"):                # interpolation nodes per decade
            lk.NODES_PER_DECADE = int(v[5:])
        elif v.startswith("bpd"):                  # bands per decade, minimum bins per band
            bpd, _, mb = v[3:].partition("m")
            pl.cross_spectra = functools.partial(pl.cross_spectra, bands_per_decade=int(bpd),
                                                 min_bins=int(mb or 8))
        elif v.startswith("shrink"):               # inflation-factor shrinkage weight
            import bayescal.core.model.inflation as inflation     # every model's
            inflation.INFLATION_SHRINK = float(v[6:])
        elif v == "quiet":                         # the reference taken as noise-free
            kw["ref_noise"] = "quiet"
        elif v.startswith("nperseg"):
            kw["nperseg"] = int(v[7:])
        else:
            raise SystemExit(f"unknown variant {v!r}")
    return kw


def laplace_z(seed, duration=3600.0, fs=10.0, band=(0.01, 1.0), case=None, coherence=None,
              **kw):
    """(coherence, {channel:kind: z}) at the least-squares point of one case:
    the coverage study's case ``seed``, or with ``case`` that case's truth
    (and ``coherence`` if given) simulated with noise and waves of ``seed``."""
    import bayescal.core.fit.run as sm
    from bayescal.pair.workflow import calibrate
    from bayescal.simulate.coverage import NOMINAL, draw_case
    from bayescal.simulate.pair import simulate_pair
    orig = sm.least_squares_fit

    def stop(model, theta0, iterations=2):
        raise _Stop(model, *orig(model, theta0, iterations=iterations))

    azs, dips, resp, coh = draw_case(seed if case is None else case)
    coh = coh if coherence is None else coherence
    sim = simulate_pair(duration=duration, fs=fs, seed=seed, coherence=coh, sut_azimuth=azs,
                        sut_dip=dips, sut_response=resp, nominal_response=NOMINAL)
    sm.least_squares_fit = stop
    try:
        calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=band,
                  fit_response="all", seed=seed, progress=False, **kw)
        raise RuntimeError("the fit did not reach least squares")
    except _Stop as got:
        model, theta, cov = got.args
    finally:
        sm.least_squares_fit = orig
    z = {}
    for k, b in enumerate(model.blocks):
        i0, i1, ig = (model.names.index(f"{b.channel_id}:{n}")
                      for n in ("c0_rel", "c1_rel", "log_gain"))
        c0, c1 = theta[i0], theta[i1]
        tn, hn = b.family.period_s, b.family.damping
        # log period, damping and log gain from the pendulum's coordinates, with
        # their gradients (the delta method carries the Laplace covariance over)
        values = (np.log(tn) - 0.5 * np.log(c0), hn * c1 / np.sqrt(c0), theta[ig])
        grads = ({i0: -0.5 / c0}, {i0: -0.5 * hn * c1 * c0 ** -1.5, i1: hn / np.sqrt(c0)},
                 {ig: 1.0})
        truth = (np.log(resp[k][0]), resp[k][1], np.log(resp[k][2]))
        for name, v, g, t in zip(("log_period", "damping", "log_gain"), values, grads, truth):
            gv = np.zeros(theta.size)
            for i, d in g.items():
                gv[i] = d
            z[f"{b.channel_id.split('.')[-1]}:{name}"] = float((v - t) / np.sqrt(gv @ cov @ gv))
    return float(coh), z


def summary(runs):
    out = {}
    for kind in ("log_period", "damping", "log_gain"):
        for label, sel in (("all", lambda c: True), ("coh<0.99", lambda c: c < 0.99),
                           ("coh>=0.99", lambda c: c >= 0.99)):
            z = np.array([v for r in runs if sel(r["coherence"])
                          for k, v in r["z"].items() if k.endswith(kind)])
            if not z.size:
                continue
            out[f"{kind} {label}"] = {"n": int(z.size), "z_sd": round(float(z.std()), 3),
                                      "z_mean": round(float(z.mean()), 3),
                                      "inside90": int(np.sum(np.abs(z) < 1.6449))}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 100), metavar=("FIRST", "STOP"))
    ap.add_argument("--variant", default="")
    ap.add_argument("--case", type=int, default=None,
                    help="hold this case's truth; the seeds vary noise and waves only")
    ap.add_argument("--coherence", type=float, default=None, help="with --case")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    kw = apply_variant(args.variant)
    runs = []
    for seed in range(*args.seeds):
        coh, z = laplace_z(seed, case=args.case, coherence=args.coherence, **kw)
        runs.append({"seed": seed, "coherence": coh, "z": z})
        print(seed, f"{coh:.4f}", {k: round(v, 2) for k, v in z.items() if "damping" in k},
              flush=True)
    table = summary(runs)
    for k, v in table.items():
        print(f"{k:24s} {v}")
    if args.out:
        study_results.write(args.out, {"variant": args.variant, "table": table, "runs": runs})


if __name__ == "__main__":
    main()
