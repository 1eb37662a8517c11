"""Closed forms the tests compare posterior spreads with, computed from the
simulated truth (never from the code under test).

Azimuth of a horizontal SUT channel ``v`` of :func:`simulate_pair` (default
noise: each channel's self-noise a fixed share of its own signal, squared
coherence ``c``): its record is ``X_f = v . g_f + N_f`` per Fourier bin with
``E|N_f|^2 = S_v(f) (1 - c) / c``. Turning ``v`` by ``d phi`` adds
``d phi p . g_f`` (``p`` the horizontal perpendicular), so the Fisher
information of the whole record in the band is

    I = 2 sum_f |p . g_f|^2 / E|N_f|^2 = 2 c / (1 - c) sum_f S_p(f) / S_v(f)

(the reference's own noise, ``ref_coherence`` 0.9999, adds 1 % to the
noise and is counted the same way). ``1 / sqrt(I)`` is the Cramer-Rao
bound: no estimator from these records has a smaller sd. The fit uses
Hann-windowed Welch segments; even without overlap their band averages
keep ``1 / sum_j |rho_j|^2 = 1 / (1 + 2 (2/3)^2 + 2 (1/6)^2) = 0.514`` of
the degrees of freedom of the span they cover (``rho_j`` the correlation of
bins ``j`` apart under the Hann window), and the 50 % overlap only adds: an
estimator that uses those segments efficiently has sd at most
``CRB * sqrt(1.944 / fraction)``, ``fraction`` the share of the record
its segments cover.
"""
from __future__ import annotations

import numpy as np

#: sum_j |rho_j|^2 of adjacent Hann-windowed bins (periodic Hann: rho_1 = -2/3,
#: rho_2 = 1/6): the degrees of freedom lost to the window at most.
HANN_DOF_LOSS = 1.0 + 2 * (2 / 3) ** 2 + 2 * (1 / 6) ** 2


def azimuth_crb_deg(sim, band, azimuth_deg, smooth=64):
    """Cramer-Rao bound (degrees) of the azimuth of a horizontal SUT channel
    pointing ``azimuth_deg`` in the simulated pair ``sim``, from the whole
    record in ``band`` (Hz). The ground's horizontal powers come from the
    reference record (three channels with one response, so ratios of their
    powers are ratios of ground powers), averaged over ``smooth`` bins."""
    fs = sim.ref[0].stats.sampling_rate
    x = np.array([tr.data for tr in sim.ref[:2]], float)
    spec = np.fft.rfft(x, axis=1)
    f = np.fft.rfftfreq(x.shape[1], 1.0 / fs)
    sel = (f >= band[0]) & (f <= band[1])
    a = np.radians(azimuth_deg)
    v, p = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
    box = np.ones(smooth) / smooth
    s_v = np.convolve(np.abs(v @ spec[:, sel]) ** 2, box, "same")
    s_p = np.convolve(np.abs(p @ spec[:, sel]) ** 2, box, "same")
    c, cr = sim.truth["coherence"], sim.truth["ref_coherence"]
    noise = (1 - c) / c + (1 - cr) / cr            # noise over signal, both sensors
    info = 2.0 / noise * np.sum(s_p / s_v)
    return float(np.degrees(1.0 / np.sqrt(info)))


def azimuth_sd_upper_deg(crb_deg, fraction):
    """Largest sd (degrees) of an efficient estimator from Hann-windowed
    segments covering ``fraction`` of the record (module docstring)."""
    return float(crb_deg * np.sqrt(HANN_DOF_LOSS / fraction))


def sd_mc_factor(ess, z):
    """Relative Monte Carlo error of a posterior sd from ``ess`` effective
    Gaussian draws (``1 / sqrt(2 ESS)``), times ``z``: an sd is compared
    with a bound to within this fraction."""
    return float(z / np.sqrt(2.0 * ess))


def check_horizontal_azimuths(summary, sim, band, cids=("XX.SIM.10.BH1", "XX.SIM.10.BH2")):
    """The horizontal azimuths of a fit's ``summary`` against the simulated
    truth: each median within ``z`` posterior sds (the median's Monte Carlo
    error added) and each sd between the Cramer-Rao bound and the Welch
    bound (:func:`azimuth_sd_upper_deg`), both widened by the sd's own Monte
    Carlo error; ``z`` the two-sided normal quantile at the suite's level
    0.001 shared over the channels (Bonferroni: 3.48 for two)."""
    from scipy.stats import norm

    from tests.tolerance import LEVEL, median_mc_error
    z = float(norm.isf(LEVEL / (2 * len(cids))))
    ess = summary["convergence"]["ess_min"]
    used = summary["meta"]["data_used"]
    fraction = used["segments"] / used["segments_possible"]
    mc = sd_mc_factor(ess, z)
    for cid in cids:
        e = summary["channels"][cid]["azimuth_deg"]
        truth = sim.truth["channels"][cid]["azimuth_deg"]
        err = (e["median"] - truth + 180.0) % 360.0 - 180.0
        assert abs(err) < z * np.hypot(e["sd"], median_mc_error(e, ess)), (cid, e, truth)
        crb = azimuth_crb_deg(sim, band, truth)
        upper = azimuth_sd_upper_deg(crb, fraction)
        assert crb * (1 - mc) <= e["sd"] <= upper * (1 + mc), (cid, e["sd"], crb, upper)


def drift_rate_crb_ppm(spectra, coherence, ref_coherence, n_channels):
    """Cramer-Rao bound (ppm) of a clock's drift rate r from the segments a
    fit used: a clock drifting at r delays the segment centred at t by
    ``r (t - t_mid)`` beside the offset at mid-record (a parameter of its
    own), so the bin at f of that segment turns by ``2 pi f r (t - t_mid)``.
    Each channel's bin carries information ``2 SNR`` per unit of phase
    squared (SNR = c / (1 - c) of the sensor under test, the reference's
    noise added as in :func:`azimuth_crb_deg`); segments overlapping by
    half count each stretch of record once (``step / nperseg``)."""
    t = np.asarray(spectra.segment_times(), float)
    f = np.asarray(spectra.freqs, float)
    snr = 1.0 / ((1 - coherence) / coherence + (1 - ref_coherence) / ref_coherence)
    info = (2 * snr * np.sum((2 * np.pi * f) ** 2) * np.sum((t - t.mean()) ** 2)
            * spectra.step / spectra.nperseg * n_channels)
    return float(1e6 / np.sqrt(info))


def band_derivatives(model, theta, step):
    """(gradient (n, B), Hessian (n, n, B)) of the per-band energies q_b of
    ``model.band_energy`` at ``theta``, central differences of steps ``step``."""
    n = theta.size
    eye = np.eye(n)
    pts = [theta + si * step[i] * eye[i] + sj * step[j] * eye[j]
           for i in range(n) for j in range(n) for si in (1, -1) for sj in (1, -1)]
    pts += [theta + s * step[i] * eye[i] for i in range(n) for s in (1, -1)]
    q = model.band_energy(np.array(pts))[0]
    h4 = q[:4 * n * n].reshape(n, n, 4, -1)
    hess = (h4[:, :, 0] - h4[:, :, 1] - h4[:, :, 2] + h4[:, :, 3]) / (4 * np.outer(step, step)[..., None])
    g2 = q[4 * n * n:].reshape(n, 2, -1)
    return (g2[:, 0] - g2[:, 1]) / (2 * step[:, None]), hess

