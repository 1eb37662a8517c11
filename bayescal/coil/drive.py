"""The coil's drive as the step and sine fits use it: the recorded input with
its own noise taken out where the drive's form is known.

The output responds to the current that flowed, not to the recorded input
``x = u + n``. A model driven by ``x`` carries the response to ``n`` as if
the sensor had felt it; regressed on it, the output's transfer comes out
attenuated by ``S_uu / (S_uu + S_nn)`` at each frequency (errors in
variables). A step's input is flat between its steps and a sine's is one
sine, where ``n`` is white and broadband; so

* sine runs: the drive is the least-squares sine (and offset) at the fitted
  frequency, :func:`sine_drive`, whose own amplitude and phase error (from
  the input's noise) :func:`with_drive_error` adds to the posterior;
* step runs: the drive is the recorded input on the samples of a transition
  (those more than ``PLATEAU_SD`` noise standard deviations from their
  plateau's level) and the plateau's median elsewhere, :func:`step_drive`.

The noise left is that of a sine's amplitude and phase fitted over the record
(relative standard deviation ``sd_n / amplitude * sqrt(2 / N)``, of the
order of the output's own at a sine: it is added to the posterior) or of a
plateau's level (averaged over the plateau's samples, far below what the
output's noise allows on a step's response). A random (PRBS)
drive has no such form: its input noise attenuates the fitted gain by
``1 / (1 + S_nn / S_uu)`` (a PRBS of amplitude ``A`` with white noise of rms
``e A``: the gain low by ``e^2``), which the spectral fit cannot tell from
the gain (docs/cal.md).
"""
from __future__ import annotations

import numpy as np

#: A sample further than this many noise standard deviations from its
#: plateau's level belongs to a transition and is kept as recorded.
PLATEAU_SD = 5.0


def sine_drive(u, fs, freq):
    """The sine (with offset) at ``freq`` Hz closest to ``u`` in least
    squares, and the standard deviation of its log-amplitude and of its
    phase (radians, the same): ``sd_n / (amplitude sqrt(N / 2))`` with
    ``sd_n`` the rms of what the sine leaves of ``u`` (the input channel's
    noise, taken as white)."""
    t = np.arange(u.size) / fs
    design = np.column_stack([np.cos(2 * np.pi * freq * t), np.sin(2 * np.pi * freq * t),
                              np.ones(u.size)])
    coef, *_ = np.linalg.lstsq(design, u, rcond=None)
    fitted = design @ coef
    sd_n = np.sqrt(np.sum((u - fitted) ** 2) / max(u.size - 3, 1))
    return fitted, float(sd_n / (np.hypot(coef[0], coef[1]) * np.sqrt(u.size / 2.0)))


def with_drive_error(samples, sd, seed=0):
    """Samples of ``(ln A, phi)`` conditional on the fitted drive, made
    marginal over its error: independent Gaussian draws of standard
    deviation ``sd`` (:func:`sine_drive`) added to both columns (the
    response's ratio to the drive is what the output measures, so the
    drive's log-amplitude and phase errors add to the response's)."""
    rng = np.random.default_rng(seed)
    return samples + sd * rng.standard_normal(samples.shape)


def step_drive(u):
    """``u`` with each plateau between steps replaced by its median, the
    samples of the transitions kept (module docstring). Steps are changes
    by more than half the input's range between neighbouring samples; with
    none, ``u`` is returned unchanged."""
    u = np.asarray(u, float)
    jumps = np.flatnonzero(np.abs(np.diff(u)) > 0.5 * np.ptp(u)) + 1
    if jumps.size == 0:
        return u
    edges = np.r_[0, jumps, u.size]
    d = np.diff(u)
    keep = np.ones(d.size, bool)
    keep[jumps - 1] = False
    # the noise's sd from the differences of neighbouring samples (robust)
    sd = 1.4826 * np.median(np.abs(d[keep] - np.median(d[keep]))) / np.sqrt(2.0)
    out = u.copy()
    for a, b in zip(edges[:-1], edges[1:]):
        level = np.median(u[a:b])
        flat = np.abs(u[a:b] - level) <= PLATEAU_SD * sd
        out[a:b][flat] = level
    return out
