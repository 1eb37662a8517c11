"""The information limit on a window's azimuths: the per-bin Fisher bound.

Written apart from bayescal's fit (numpy and ObsPy only), so that it can
judge the fit's interval widths. For one window of a pair (files, band,
start and end, as ``bayescal fit`` takes them) and each SUT horizontal:

* per segment ``k`` and bin ``f`` (Hann segments, linear detrend, Welch
  layout), the SUT channel is ``X = beta^T Y + n`` with ``Y`` the reference's
  horizontals (taken as given: noise-free regressors) and
  ``beta = g (cos phi, sin phi)`` (``phi`` the channel's azimuth relative to
  the reference, ``g`` its gain, a nuisance);
* the noise power ``sigma_f^2`` of each bin is the mean residual power after
  the band's least-squares ``beta``, averaged over three neighbouring bins
  (the noise spectrum is smooth; one bin's 17 segments alone would bias
  ``1 / sigma^2`` upward);
* the Fisher information of ``beta`` in bin ``f`` is
  ``I_f = 2 Re(sum_k Y_kf^* Y_kf^T) / sigma_f^2`` (complex circular noise);
* the samples are not independent: neighbouring bins of a Hann window and
  overlapping segments are correlated. With ``rho(l, d)`` the correlation of
  white noise between the DFTs of two segments ``l`` samples apart and
  ``d`` bins apart, ``r(d) = sum_{k,k'} |rho(s_k' - s_k, d)|^2 / K`` over the
  segments used, and the covariance of the least-squares estimate of
  ``beta`` is the sandwich ``A^-1 B A^-1`` with ``A = sum_f I_f`` and
  ``B = sum_{f,f'} r(f - f') sym(I_f^1/2 I_f'^1/2)`` (for a spectrum flat over
  the band this is ``A^-1`` times ``M / nu``, ``nu`` the effective number of
  independent averages of the Welch estimate);
* the azimuth's variance with the gain a nuisance is
  ``u_perp^T Cov(beta) u_perp / g^2``, ``u_perp = (-sin phi, cos phi)``;
  the 95 % width is ``2 x 1.96`` times its square root.

``simulate`` checks it where the truth's scatter is measurable: many seeded
pairs with a known azimuth, coloured ground and coloured SUT noise, the
weighted least-squares estimate with the true noise spectrum; the scatter of
its azimuths over the seeds must equal the bound within the sampling error
of a standard deviation.

    python validation/studies/fisher_bound.py window --start 2010-08-24T09:00:00 --end 2010-08-24T09:10:00
    python validation/studies/fisher_bound.py simulate --seeds 400

``window`` defaults to the shared COWI pair (../shared/data/real/asl_cowi_azimuth)
and 1/8-1/3 Hz; ``simulate`` writes validation/results/fisher_bound/simulation.json.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
COWI = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
Z95 = 1.959963984540054


# --- spectra ----------------------------------------------------------------
def hann(n):
    """Periodic Hann window of ``n`` samples."""
    return 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)


def segment_dfts(x, nperseg, step):
    """(K, C, F) DFTs of linearly detrended, Hann-windowed segments of
    ``x`` (C, N), segments starting every ``step`` samples; and the starts."""
    x = np.atleast_2d(np.asarray(x, float))
    starts = np.arange(0, x.shape[1] - nperseg + 1, step)
    seg = x[:, starts[:, None] + np.arange(nperseg)].transpose(1, 0, 2)        # (K, C, n)
    t = np.arange(nperseg) - (nperseg - 1) / 2.0
    seg = seg - seg.mean(axis=-1, keepdims=True)
    seg = seg - t * (seg @ t)[..., None] / (t @ t)
    return np.fft.rfft(seg * hann(nperseg), axis=-1), starts


def pair_correlation(nperseg, starts, max_bins):
    """``r(d)`` for ``d = 0 .. max_bins``: sum over ordered segment pairs of
    ``|rho(lag, d)|^2`` divided by the number of segments (1 at ``d = 0``
    for segments that do not overlap)."""
    w = hann(nperseg)
    norm = np.sum(w * w)
    lags = np.abs(starts[:, None] - starts[None, :]).ravel()
    lags = lags[lags < nperseg]
    out = np.zeros(max_bins + 1)
    for lag, count in zip(*np.unique(lags, return_counts=True)):
        prod = np.zeros(nperseg)
        prod[:nperseg - lag] = w[lag:] * w[:nperseg - lag]
        rho = np.fft.fft(prod)[:max_bins + 1] / norm
        out += count * np.abs(rho) ** 2
    return out / starts.size


# --- the bound ----------------------------------------------------------------
def _sqrtm(m):
    v, u = np.linalg.eigh(m)
    return (u * np.sqrt(np.clip(v, 0, None))) @ u.T


def beta_covariance(yy, sigma2, r):
    """Sandwich covariance of the weighted least-squares ``beta``.

    ``yy`` (F, 2, 2) complex ``sum_k Y^* Y^T`` per bin, ``sigma2`` (F,) noise
    power per bin, ``r`` (>= F,) the pair correlation by bin distance.
    Returns (covariance (2, 2), naive covariance ``A^-1`` (2, 2))."""
    info = 2 * np.real(yy) / sigma2[:, None, None]                          # (F, 2, 2)
    a_inv = np.linalg.inv(info.sum(axis=0))
    roots = np.stack([_sqrtm(i) for i in info])
    n = info.shape[0]
    d = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    cross = np.einsum("fg,fij,gjk->ik", r[d], roots, roots)
    b = 0.5 * (cross + cross.T)
    return a_inv @ b @ a_inv, a_inv


def azimuth_sd(beta, cov):
    """Standard deviation (rad) of ``phi = atan2(beta_2, beta_1)`` with the
    gain ``|beta|`` a nuisance."""
    g = np.hypot(*beta)
    u = np.array([-beta[1], beta[0]]) / g
    return float(np.sqrt(u @ cov @ u) / g)


def least_squares(x, y, weight):
    """Weighted least-squares ``beta`` (2,) of ``x`` (K, F) on ``y`` (K, 2, F),
    weights (F,) per bin: real ``beta`` for complex data."""
    yy = np.einsum("kif,kjf->fij", y.conj(), y)
    yx = np.einsum("kif,kf->fi", y.conj(), x)
    a = np.einsum("f,fij->ij", weight, np.real(yy))
    return np.linalg.solve(a, np.einsum("f,fi->i", weight, np.real(yx))), yy


def channel_bound(x, y, r, smooth=1):
    """Per-bin Fisher bound for one SUT channel.

    ``x`` (K, F) SUT DFTs, ``y`` (K, 2, F) reference DFTs (the analysis band's
    bins), ``r`` the pair correlation. Returns a dict: azimuth (deg, from
    the unweighted least squares then reweighted once), sd and 95 % width
    (deg) with the correlation counted, the same without it, and the noise
    power per bin."""
    beta, yy = least_squares(x, y, np.ones(x.shape[1]))
    for _ in range(2):                         # reweight by the residual power
        res = np.mean(np.abs(x - np.einsum("i,kif->kf", beta, y)) ** 2, axis=0)
        if smooth:
            k = np.ones(2 * smooth + 1)
            res = np.convolve(res, k, "same") / np.convolve(np.ones_like(res), k, "same")
        beta, yy = least_squares(x, y, 1 / res)
    cov, naive = beta_covariance(yy, res, r)
    sd, sd0 = azimuth_sd(beta, cov), azimuth_sd(beta, naive)
    return {"azimuth_deg": float(np.degrees(np.arctan2(beta[1], beta[0]))),
            "gain": float(np.hypot(*beta)),
            "sd_deg": float(np.degrees(sd)), "width95_deg": float(np.degrees(2 * Z95 * sd)),
            "width95_independent_deg": float(np.degrees(2 * Z95 * sd0)),
            "noise_power": res}


def bound(sut, ref, fs, band, nperseg, overlap=0.5, smooth=1, use=None):
    """Per-bin Fisher bound of each SUT channel (rows of ``sut`` (C, N))
    against the two reference horizontals ``ref`` (2, N, at azimuths 0 and
    90 degrees), band (Hz), segments of ``nperseg`` samples; ``use``: the
    start samples of the segments to count (None: all)."""
    step = int(round(nperseg * (1 - overlap)))
    xs, starts = segment_dfts(sut, nperseg, step)
    ys, _ = segment_dfts(ref, nperseg, step)
    if use is not None:
        pick = np.isin(starts, np.asarray(use, int))
        xs, ys, starts = xs[pick], ys[pick], starts[pick]
    f = np.fft.rfftfreq(nperseg, 1 / fs)
    keep = (f >= band[0]) & (f <= band[1])
    r = pair_correlation(nperseg, starts, int(keep.sum()))
    out = []
    for c in range(xs.shape[1]):
        b = channel_bound(xs[:, c, keep], ys[:, :, keep], r, smooth)
        b.pop("noise_power")
        out.append(b)
    return out, {"segments": int(starts.size), "bins": int(keep.sum()),
                 "independent_averages_ratio": float(1 / np.sum(np.r_[r[0], 2 * r[1:]]))}


# --- real windows ------------------------------------------------------------
def read_window(sut_file, ref_files, start, end, channels=("LHN", "LHE")):
    """(sut (C, N), ref (2, N), fs) between ``start`` and ``end`` read with ObsPy:
    SUT channels by code, the reference's two traces in file order."""
    import obspy
    t0, t1 = obspy.UTCDateTime(start), obspy.UTCDateTime(end)
    sut = obspy.read(str(sut_file))
    ref = obspy.Stream()
    for f in ref_files:
        ref += obspy.read(str(f))
    rows = []
    for st in [sut.select(channel=c) for c in channels] + [ref.select(channel=t.stats.channel)
                                                           for t in _unique(ref)]:
        s = st.slice(t0, t1 - 0.5 / st[0].stats.sampling_rate, nearest_sample=True)
        s.merge()
        if len(s) != 1 or np.ma.is_masked(s[0].data):
            raise ValueError(f"{st[0].id}: a gap between {t0} and {t1}")
        rows.append(np.asarray(s[0].data, float))
    n = min(len(r) for r in rows)
    data = np.stack([r[:n] for r in rows])
    return data[:len(channels)], data[len(channels):], float(sut[0].stats.sampling_rate)


def _unique(st):
    seen, out = set(), []
    for t in st:
        if t.stats.channel not in seen:
            seen.add(t.stats.channel)
            out.append(t)
    return out


def window_bound(start, end, band=(0.125, 0.3333), segment_s=64.0, data=COWI,
                 channels=("LHN", "LHE"), use=None):
    """The bound of each COWI channel (dict by channel) in one window;
    ``use``: start samples (from the window's start) of the segments to count."""
    sut, ref, fs = read_window(data / "C100823215422_COWI.LHx",
                               [data / "DT000110.LH1", data / "DT000110.LH2"], start, end, channels)
    per, layout = bound(sut, ref, fs, band, int(round(segment_s * fs)), use=use)
    return {c: p for c, p in zip(channels, per)}, layout


# --- the check on simulated pairs ----------------------------------------------
def _ar2(n, f0, q, rng, fs=1.0):
    """AR(2) resonance near ``f0`` Hz (quality ``q``) driven by white noise."""
    rad = np.exp(-np.pi * f0 / (q * fs))
    a1, a2 = 2 * rad * np.cos(2 * np.pi * f0 / fs), -rad * rad
    e = rng.standard_normal(n + 500)
    x = np.zeros_like(e)
    for i in range(2, e.size):
        x[i] = a1 * x[i - 1] + a2 * x[i - 2] + e[i]
    return x[500:], (a1, a2)


def _ar2_psd(f, coef, fs=1.0):
    z = np.exp(-2j * np.pi * f / fs)
    return 1.0 / np.abs(1 - coef[0] * z - coef[1] * z * z) ** 2


def simulate_one(seed, n=600, phi_deg=3.2, gain=1.0, nperseg=64, band=(0.125, 0.3333),
                 noise=(0.6, 0.15)):
    """One pair: its true-weight estimate of the azimuth (deg) and its bound."""
    rng = np.random.default_rng(seed)
    g1, coef = _ar2(n, 0.18, 4.0, rng)
    g2, _ = _ar2(n, 0.18, 4.0, rng)
    ground = np.stack([g1, g2])
    # SUT noise: white plus a red part (rising toward the band's bottom)
    red_coef = (0.9, 0.0)
    red = np.zeros(n + 500)
    e = rng.standard_normal(n + 500)
    for i in range(1, red.size):
        red[i] = 0.9 * red[i - 1] + e[i]
    phi = np.radians(phi_deg)
    x = gain * (np.cos(phi) * ground[0] + np.sin(phi) * ground[1]) \
        + noise[0] * rng.standard_normal(n) + noise[1] * red[500:]
    step = nperseg // 2
    xs, starts = segment_dfts(x[None], nperseg, step)
    ys, _ = segment_dfts(ground, nperseg, step)
    f = np.fft.rfftfreq(nperseg)
    keep = (f >= band[0]) & (f <= band[1])
    true_power = noise[0] ** 2 + noise[1] ** 2 * _ar2_psd(f[keep], red_coef)
    beta, _ = least_squares(xs[:, 0, keep], ys[:, :, keep], 1 / true_power)
    r = pair_correlation(nperseg, starts, int(keep.sum()))
    est = channel_bound(xs[:, 0, keep], ys[:, :, keep], r)
    # the bound with the true noise spectrum (DFT units: PSD times sum w^2)
    yy = np.einsum("kif,kjf->fij", ys[:, :, keep].conj(), ys[:, :, keep])
    cov, naive = beta_covariance(yy, true_power * np.sum(hann(nperseg) ** 2), r)
    b_true = np.array([gain * np.cos(phi), gain * np.sin(phi)])
    return {"seed": seed, "estimate_deg": float(np.degrees(np.arctan2(beta[1], beta[0]))),
            "bound_sd_deg": est["sd_deg"],
            "bound_sd_true_noise_deg": float(np.degrees(azimuth_sd(b_true, cov))),
            "bound_sd_independent_deg": float(np.degrees(azimuth_sd(b_true, naive)))}


def simulate(seeds, phi_deg=3.2):
    """Scatter of the true-weight estimate over ``seeds`` against the bound."""
    runs = [simulate_one(s, phi_deg=phi_deg) for s in seeds]
    est = np.array([r["estimate_deg"] for r in runs])
    n = est.size
    scatter = float(np.sqrt(np.mean((est - phi_deg) ** 2)))
    out = {"seeds": [int(seeds[0]), int(seeds[-1])], "n": n, "truth_deg": phi_deg,
           "mean_error_deg": float(est.mean() - phi_deg),
           "scatter_sd_deg": scatter}
    for key in ("bound_sd_deg", "bound_sd_true_noise_deg", "bound_sd_independent_deg"):
        b = float(np.sqrt(np.mean([r[key] ** 2 for r in runs])))
        out[key.replace("_deg", "_rms_deg")] = b
        out["scatter_over_" + key.replace("_deg", "")] = scatter / b
    # the sd of n draws about a known mean: relative sampling error 1/sqrt(2n)
    z = 2.5758293035489
    out["band99_for_ratio"] = [1 - z / np.sqrt(2 * n), 1 + z / np.sqrt(2 * n)]
    return out, runs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("window", help="the bound of one window of the COWI pair")
    w.add_argument("--start", required=True)
    w.add_argument("--end", required=True)
    w.add_argument("--band", nargs=2, type=float, default=(0.125, 0.3333))
    w.add_argument("--segment-s", type=float, default=64.0)
    w.add_argument("--data", type=Path, default=COWI)
    w.add_argument("--use", type=int, nargs="+", default=None,
                   help="start samples (from --start) of the segments to count; default all")
    s = sub.add_parser("simulate", help="the bound against the scatter of simulated pairs")
    s.add_argument("--seeds", type=int, default=400)
    s.add_argument("--out", default=str(ROOT / "validation" / "results" / "fisher_bound"
                                         / "simulation.json"))
    a = ap.parse_args(argv)
    if a.cmd == "window":
        if not a.data.is_dir():
            sys.exit(f"data folder {a.data} not found (see ../shared/data/README.md)")
        per, layout = window_bound(a.start, a.end, tuple(a.band), a.segment_s, a.data, use=a.use)
        print(json.dumps({"window": [a.start, a.end], "band_hz": a.band, **layout, **per},
                         indent=1))
        return 0
    t0 = time.time()
    out, runs = simulate(np.arange(a.seeds))
    out["command"] = f"python validation/studies/fisher_bound.py simulate --seeds {a.seeds}"
    out["seconds"] = round(time.time() - t0, 1)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
