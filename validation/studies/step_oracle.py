"""Step runs of ``validation/studies/cal_coverage.py`` under the exact noise model:
is the step intervals' excess scatter the AR noise model's doing?

For each seeded step run (the truths and seeds of ``cal_coverage.py``'s
step section) two standardised errors ``(estimate - truth) / sd`` of
``(ln T, h, ln G)``:

* ``AR``: the pipeline's least-squares point and Laplace sd
  (:func:`bayescal.coil.step.least_squares_step`, AR noise by BIC);
* ``exact``: the linearised generalised-least-squares estimate with the
  simulator's own noise spectrum (white self-noise through the true
  response plus the digitizer's white noise; the simulator draws each DFT
  coefficient independently, so this Whittle likelihood is exact), drift
  projected out as in the model.

Under a correct model both have sd 1 over many runs. Also printed: the AR
innovations' power at the *truth* per frequency band over its nominal value
(1 where the AR spectrum is right), averaged over the runs.

    python validation/studies/step_oracle.py --first 0 --last 100
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from scipy.fft import rfft

from cal_coverage import COIL, _step_run  # the sibling study, run as a script

from bayescal.coil.step import least_squares_step
from bayescal.core.response import pendulum  # noqa: E402
from bayescal.core.response.family import paz_velocity_response  # noqa: E402
from bayescal.simulate.pair import DIGITIZER_GAIN, NORM_FREQ  # noqa: E402


def truth_theta(model, truth):
    """The step model's coordinates (c0_rel, c1_rel, ln G) of a truth
    (period, damping, gain)."""
    fam = model.spec.family
    return np.r_[pendulum.from_physical(truth[0], truth[1], fam.period_s, fam.damping),
                 np.log(truth[2])]


def exact_z(model, truth, noise_ratio, amplitude=1e5, digitizer=1.0):
    """Linearised GLS error over its sd with the simulator's noise spectrum."""
    th = truth_theta(model, truth)
    n = model.x.size
    kf = np.arange(1, (n - 1) // 2 + 1)
    f = kf * model.fs / n
    k = paz_velocity_response(f, *truth, digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)
    s = np.abs(k / (2j * np.pi * f)) ** 2 * (noise_ratio * COIL * amplitude) ** 2 * n + n * digitizer

    def white(y):
        c = rfft(y, axis=-1)[..., kf] / np.sqrt(s / 2)
        return np.concatenate([c.real, c.imag], axis=-1)

    t = np.arange(n) / model.fs
    q = white(t - t.mean())
    q /= np.linalg.norm(q)
    h = 1e-5
    jac = np.column_stack([(white(model.predict(th + d)[0]) - white(model.predict(th - d)[0]))
                           / (2 * h) for d in np.eye(3) * h])
    jac -= np.outer(q, q @ jac)
    r = white(model.x - model.predict(th)[0])
    r -= q * (q @ r)
    cov = np.linalg.inv(jac.T @ jac)
    return cov @ jac.T @ r / np.sqrt(np.diag(cov))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--last", type=int, default=100)
    ap.add_argument("--fs", type=float, default=10.0)
    ap.add_argument("--noise-ratio", type=float, default=0.01)
    args = ap.parse_args()
    za, ze, ratio = [], [], []
    edges = np.array([1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1, 1.0])
    for i in range(args.first, args.last):
        truth, run = _step_run(i, args.fs, args.noise_ratio)
        model, _, theta, cov = least_squares_step(run, COIL)
        th = truth_theta(model, truth)
        za.append((theta - th) / np.sqrt(np.diag(cov)))
        ze.append(exact_z(model, truth, args.noise_ratio))
        e = model.innovations(th[None])[0]
        p = np.abs(np.fft.rfft(e)) ** 2 / e.size
        f = np.fft.rfftfreq(e.size, 1.0 / model.fs)
        ratio.append([p[(f >= a) & (f < b)].mean() for a, b in zip(edges[:-1], edges[1:])])
    print("AR innovation power at the truth / nominal, bands (Hz)", edges, ":",
          np.round(np.mean(ratio, 0), 2))
    for name, z in (("AR (pipeline, Laplace)", np.array(za)), ("exact noise", np.array(ze))):
        print(f"{name}: runs {len(z)}, z sd (ln T, h, ln G) {np.round(z.std(0, ddof=1), 3)}, "
              f"mean {np.round(z.mean(0), 3)}, inside 95 % {(np.abs(z) < 1.96).sum(0)}")


if __name__ == "__main__":
    main()
