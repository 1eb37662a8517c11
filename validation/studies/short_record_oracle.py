"""Short records: is the plug-in noise model what makes the intervals narrow?

On 900-s pairs over 0.02-1 Hz (2048-sample segments, 5 of them; the
"Short records" case of ``docs/validation/errors_in_variables.md``) each pair is fitted
to its least-squares point three times, with the angles' and gains'
standardised errors taken from the Laplace (inverse Fisher) sd, which the
MCMC intervals follow to within the per-band misfit term (about 1.0-1.2
times):

* plug-in: the noise model as ``bayescal fit`` estimates it, from the record;
* long-record noise: the noise model (the per-band noise covariance and its
  inflation factors) of a record ``--long`` times longer of the same
  sensors and the same ground field, rescaled to the short record;
* long-record covariance: only the per-band noise covariance from the long
  record, the inflation factors estimated as usual.

A noise model that is right by construction is not available from a pair,
so the long record stands in for it. By default ``simulate_pair`` draws the
plane waves' parameters from the same generator as the per-bin noise, so
the same seed at another duration is another ground field with another
noise level; both records here are simulated with ``wave_seed=seed``, one
ground field at both lengths (statistically the same population as the
default draws, not the same pairs).

Also printed: per band, ``tr(S_short^-1 S_long) / 3`` averaged over pairs
(1 for a right covariance; a complex-Wishart covariance of ``n`` samples
gives ``n / (n - 3)``).

    python validation/studies/short_record_oracle.py --out validation/results/eiv/short_record_oracle.json   # 100 pairs, about 10 min
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import eiv_coverage as ec                      # the sibling study, run as a script


class _Stop(Exception):
    pass


def least_squares_point(sim, seed, nperseg, noise=None, which="both"):
    """(model, theta, covariance) at the least-squares point of
    ``bayescal.calibrate`` (gains fitted, quiet reference); with ``noise``
    (a long record's noise model and its length factor) the model's noise
    estimate is replaced by it (``which``: "both" or "sigma")."""
    import bayescal.core.fit.run as sm
    orig = sm.least_squares_fit

    def stop(model, theta0, iterations=2, jac=None):
        if noise is not None:
            other, factor = noise
            own_estimate = model.estimate_noise

            def estimate(theta):
                own = own_estimate(theta)
                sigma = other.sigma * factor
                c = other.inflation if which == "both" else own.inflation
                return model.adopt_noise(type(own)(
                    A=np.linalg.inv(sigma) / c[:, None, None], B=own.B, sigma=sigma,
                    inflation=c, scale0=own.scale0))
            model.estimate_noise = estimate
        raise _Stop(model, *orig(model, theta0, iterations=iterations))

    sm.least_squares_fit = stop
    try:
        ec.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.02, 1.0),
                     fit_response="gain", seed=seed, progress=False, ref_noise="quiet",
                     nperseg=nperseg)
    except _Stop as got:
        return got.args
    finally:
        sm.least_squares_fit = orig
    raise RuntimeError("the fit did not reach least squares")


def laplace_z(model, theta, cov, azs, resp):
    """Standardised errors of the two horizontals' azimuths and the three
    gains, the sd from ``cov`` (azimuths by the delta method)."""
    def azimuths(th):
        v, _ = model.unpack(np.atleast_2d(th))
        return np.degrees(np.arctan2(v[0, :, 1], v[0, :, 0]))
    eps = 1e-6
    jac = np.array([(azimuths(theta + eps * e) - azimuths(theta - eps * e)) / (2 * eps)
                    for e in np.eye(theta.size)]).T
    sd = np.sqrt(np.einsum("ij,jk,ik->i", jac, cov, jac))
    az = azimuths(theta)
    z = [(((az[k] - azs[k] + 180) % 360) - 180) / sd[k] for k in range(2)]
    for k, b in enumerate(model.blocks):
        i = model.names.index(f"{b.channel_id}:log_gain")
        z.append((theta[i] - np.log(resp[k][2])) / np.sqrt(cov[i, i]))
    return z


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(900, 1000), metavar=("FIRST", "STOP"))
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--nperseg", type=int, default=2048)
    ap.add_argument("--long", type=float, default=10.0, help="the long record's length factor")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    from bayescal.simulate import simulate_pair
    t0 = time.time()
    zs = {"plug-in": [], "long-record noise": [], "long-record covariance": []}
    ratio = []
    for seed in range(*args.seeds):
        azs, dips, resp = ec.draw_truth(seed, "gain")
        cu, cr = ec.coherences(0.9, 0)
        kw = dict(fs=10, coherence=cu, ref_coherence=cr, sut_azimuth=azs, sut_dip=dips,
                  sut_response=resp, nominal_response=ec.NOMINAL, noise_in_counts=True)
        short = simulate_pair(duration=args.duration, seed=seed, wave_seed=seed, **kw)
        long_ = simulate_pair(duration=args.duration * args.long, seed=seed + 50000,
                              wave_seed=seed, **kw)
        ml = least_squares_point(long_, seed, args.nperseg)[0]
        # the simulator's per-bin amplitudes make a record's spectra scale
        # as 1 / its length: the long record's noise, rescaled
        noise = (ml.noise, args.long)
        m, th, cov = least_squares_point(short, seed, args.nperseg)
        zs["plug-in"].append(laplace_z(m, th, cov, azs, resp))
        s_short, s_long = m.noise.sigma, ml.noise.sigma * args.long
        ratio.append([np.trace(np.linalg.solve(s_short[b], s_long[b])).real / 3
                      for b in range(s_short.shape[0])])
        for name, which in (("long-record noise", "both"), ("long-record covariance", "sigma")):
            zs[name].append(laplace_z(*least_squares_point(short, seed, args.nperseg,
                                                           noise, which), azs, resp))
        print(f"seed {seed}: " + "; ".join(f"{k} {np.round(v[-1], 2).tolist()}"
                                            for k, v in zs.items()), file=sys.stderr, flush=True)
    n_b = m.spectra.bins_per_band * m.spectra.n_segments
    out = {"settings": vars(args), "seconds": time.time() - t0,
           "bands_hz": m.spectra.band_edges.tolist(), "samples_per_band": n_b.tolist(),
           "covariance_ratio_by_band": np.mean(ratio, axis=0).round(3).tolist(),
           "wishart_ratio_by_band": (n_b / (n_b - 3)).round(3).tolist(), "variants": {}}
    for name, z in zs.items():
        z = np.array(z)
        az, gain = z[:, :2].ravel(), z[:, 2:].ravel()
        out["variants"][name] = {"azimuth_z_sd": float(az.std(ddof=1)),
                                 "azimuth_in90": int(np.sum(np.abs(az) < 1.6449)),
                                 "n_azimuth": int(az.size),
                                 "gain_z_sd": float(gain.std(ddof=1)),
                                 "gain_in90": int(np.sum(np.abs(gain) < 1.6449)),
                                 "n_gain": int(gain.size)}
        v = out["variants"][name]
        print(f"{name}: azimuth z sd {v['azimuth_z_sd']:.2f} ({v['azimuth_in90']}/{v['n_azimuth']} "
              f"in 90 %), gain z sd {v['gain_z_sd']:.2f} ({v['gain_in90']}/{v['n_gain']})")
    print("tr(S_short^-1 S_long)/3 by band:", out["covariance_ratio_by_band"],
          "complex Wishart n/(n-3):", out["wishart_ratio_by_band"])
    if args.out:
        os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
        with open(args.out, "w") as fh:
            json.dump(out, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
