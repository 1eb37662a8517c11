"""Three co-located vertical sensors with known self-noise: the truth against
which :mod:`bayescal.core.selfnoise.sleeman` and ``bayescal noise`` are checked.

Two STS-1 and one Trillium 240 (the nominal poles and zeros of the II.XPFO
sensors, Q330HR digitizer) record one ground acceleration (Peterson's NLNM +
10 dB) plus independent self-noise of three kinds:

* sensor 0: white in ground acceleration, -185 dB re 1 (m/s^2)^2/Hz;
* sensor 1: white in ground velocity, -190 dB at 1 Hz (+20 dB per decade);
* sensor 2: white in counts (digitizer-like), -180 dB at 1 Hz in acceleration.

So the ratio of ambient signal to self-noise runs from about 0 to 60 dB over
0.1-100 s and differs between the sensors. With ``axis_mismatch`` each
sensor's axis is tilted by that many rad rms in each horizontal direction and
sees independent horizontal ground motion (PSD equal to the vertical): the
model error the interval's allowance is about. Series are synthesised in the
frequency domain (one FFT of the whole record, so exactly stationary).
:meth:`Colocated.write` puts each sensor's miniSEED and StationXML in a
folder with ``truth.json``: each sensor's true self-noise, in dB re 1
(m/s^2)^2/Hz at a list of periods, beside the ground motion's PSD
(:meth:`Colocated.truth`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..core.response import transfer

#: Nominal responses (rad/s; generator constant V/(m/s)), ../shared/data/README.md.
STS1 = dict(zeros=[0j, 0j], poles=[-0.01234 + 0.01234j, -0.01234 - 0.01234j,
                                     -39.18 + 49.12j, -39.18 - 49.12j], generator=2200.0)
T240 = dict(zeros=[0j, 0j, -108 + 0j, -161 + 0j],
            poles=[-0.0182 + 0.018j, -0.0182 - 0.018j, -196 + 231j, -196 - 231j,
                   -732 + 1450j, -732 - 1450j, -173 + 0j], generator=1200.0)
#: Q330HR digitizer, counts per V.
DIGITIZER = 2 ** 26 / 40.0
SENSORS = (STS1, T240, STS1)
LOCATIONS = ("00", "10", "60")
#: Ground acceleration: Peterson's NLNM plus this many dB.
GROUND_ABOVE_NLNM_DB = 10.0


def paz_response(s, norm_freq=1.0):
    """numpy velocity response (counts per m/s) of one nominal sensor,
    normalised to ``generator * DIGITIZER`` at ``norm_freq``."""
    z, p = np.array(s["zeros"]), np.array(s["poles"])

    def raw(f):
        return transfer(2j * np.pi * np.asarray(f, float), z, p)
    scale = s["generator"] * DIGITIZER / abs(raw(norm_freq))
    return lambda f: scale * raw(f)


RESPONSES = tuple(paz_response(s) for s in SENSORS)


def ground_acceleration_psd(f):
    """(m/s^2)^2/Hz of the simulated vertical ground acceleration."""
    from obspy.signal.spectral_estimation import get_nlnm

    p, nl = get_nlnm()
    f = np.asarray(f, float)
    return 10 ** ((np.interp(np.log(1 / f), np.log(p[::-1]), nl[::-1])
                   + GROUND_ABOVE_NLNM_DB) / 10)


def _counts_psd():
    """Counts PSD of sensor 2's noise: -180 dB in acceleration at 1 Hz."""
    return 1e-18 * abs(RESPONSES[2](1.0)) ** 2 / (2 * np.pi) ** 2


def noise_acceleration_psd(i, f):
    """True self-noise of sensor ``i`` (0, 1, 2), (m/s^2)^2/Hz."""
    f = np.asarray(f, float)
    if i == 0:
        return np.full(f.shape, 10 ** -18.5)
    if i == 1:
        return 1e-19 * f ** 2
    return _counts_psd() * (2 * np.pi * f) ** 2 / np.abs(RESPONSES[2](f)) ** 2


def true_band_noise(spectra):
    """(3, B) true self-noise per band of ``spectra`` (a
    :class:`bayescal.core.spectra.welch.CrossSpectra` of the three channels), with
    the band definition of :func:`bayescal.core.selfnoise.sleeman.acceleration_band_matrices`."""
    f = spectra.freqs
    w2 = (2 * np.pi * f) ** 2
    nb = spectra.bins_per_band
    inv_w2 = np.bincount(spectra.band_of, weights=1 / w2) / nb
    return np.array([np.bincount(spectra.band_of, weights=noise_acceleration_psd(i, f) / w2)
                     / nb / inv_w2 for i in range(3)])


@dataclass
class Colocated:
    """Simulated recordings of the three sensors: ``data`` (3, N) counts."""

    data: np.ndarray
    fs: float
    seed: int
    axis_mismatch: float
    starttime: str = "2020-01-01T00:00:00"

    def response_fn(self):
        """Callable freqs -> (3, F) complex responses (counts per m/s)."""
        return lambda f: np.array([r(f) for r in RESPONSES])

    def streams(self, dtype=np.float64):
        """One ObsPy Stream per sensor (XS.SIM.<loc>.BHZ)."""
        import obspy

        out = []
        for loc, x in zip(LOCATIONS, self.data):
            tr = obspy.Trace(np.ascontiguousarray(x, dtype=dtype),
                             header=dict(network="XS", station="SIM", location=loc,
                                         channel="BHZ", sampling_rate=self.fs,
                                         starttime=obspy.UTCDateTime(self.starttime)))
            out.append(obspy.Stream([tr]))
        return out

    def inventories(self):
        """One nominal Inventory per sensor (the simulation's exact responses)."""
        from ..io.read import paz_inventory

        return [paz_inventory(st, zeros=s["zeros"], poles=s["poles"],
                              gain=s["generator"] * DIGITIZER, norm_freq=1.0)
                for st, s in zip(self.streams(), SENSORS)]

    def truth(self, n_periods=40):
        """The simulation's truth (what ``truth.json`` holds): per sensor
        (SEED id) its kind of self-noise and that noise's PSD in dB re 1
        (m/s^2)^2/Hz at ``period_s`` (log-spaced from 2.5 samples to the
        shorter of 1000 s and a tenth of the record), the ground motion's
        PSD there, and the run's settings."""
        period = np.geomspace(2.5 / self.fs, min(1000.0, self.data.shape[1] / self.fs / 10),
                              n_periods)
        f = 1.0 / period
        kinds = ("white in ground acceleration, -185 dB",
                 "white in ground velocity, -190 dB at 1 Hz (+20 dB per decade)",
                 "white in counts (digitizer-like), -180 dB at 1 Hz in acceleration")
        sensors = {f"XS.SIM.{loc}.BHZ": {
            "sensor": "Trillium 240" if s is T240 else "STS-1", "noise": kind,
            "noise_psd_db": np.round(10 * np.log10(noise_acceleration_psd(i, f)), 3).tolist()}
            for i, (loc, s, kind) in enumerate(zip(LOCATIONS, SENSORS, kinds))}
        return {"units": "dB re 1 (m/s^2)^2/Hz", "period_s": period.tolist(),
                "ground_psd_db": np.round(10 * np.log10(ground_acceleration_psd(f)), 3).tolist(),
                "ground": f"Peterson's NLNM + {GROUND_ABOVE_NLNM_DB:g} dB", "sensors": sensors,
                "sampling_rate": self.fs, "duration_s": self.data.shape[1] / self.fs,
                "seed": self.seed, "axis_mismatch_rad": self.axis_mismatch}

    def write(self, folder):
        """miniSEED and StationXML per sensor, and ``truth.json``
        (:meth:`truth`: each sensor's true self-noise) in ``folder``;
        returns (data paths, xml paths)."""
        import json

        os.makedirs(folder, exist_ok=True)
        data, xml = [], []
        for loc, st, inv in zip(LOCATIONS, self.streams(), self.inventories()):
            data.append(os.path.join(folder, f"XS.SIM.{loc}.BHZ.mseed"))
            xml.append(os.path.join(folder, f"XS.SIM.{loc}.BHZ.xml"))
            st.write(data[-1], format="MSEED")
            inv.write(xml[-1], format="STATIONXML")
        with open(os.path.join(folder, "truth.json"), "w") as fh:
            json.dump(self.truth(), fh, indent=1)
        return data, xml


def _coloured(rng, n, fs, psd):
    """Spectrum of a real series of ``n`` samples with one-sided PSD ``psd``."""
    X = np.sqrt(n * fs * psd / 2) * (rng.standard_normal(psd.size)
                                      + 1j * rng.standard_normal(psd.size)) / np.sqrt(2)
    X[0] = X[-1] = 0
    return X


def simulate_colocated(duration=7200.0, fs=20.0, seed=0, axis_mismatch=0.0):
    """:class:`Colocated` recordings of ``duration`` s at ``fs`` Hz."""
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    f = np.fft.rfftfreq(n, 1 / fs)
    fp = np.where(f > 0, f, 1.0)
    w2 = (2 * np.pi * fp) ** 2
    ground_v = ground_acceleration_psd(fp) / w2
    gv = _coloured(rng, n, fs, ground_v)
    gh = [_coloured(rng, n, fs, ground_v) for _ in range(2)] if axis_mismatch else []
    out = []
    for i in range(3):
        H = RESPONSES[i](fp)
        eps = rng.standard_normal(2) * axis_mismatch
        ground = gv + sum(e * g for e, g in zip(eps, gh))
        if i < 2:      # noise in ground units, through the response
            X = H * (ground + _coloured(rng, n, fs, noise_acceleration_psd(i, fp) / w2))
        else:          # noise white in counts, after the response
            X = H * ground + _coloured(rng, n, fs, np.full(f.size, _counts_psd()))
        X[0] = 0
        out.append(np.fft.irfft(X, n=n))
    return Colocated(np.array(out), float(fs), seed, axis_mismatch)


def estimate_and_truth(sim, band=None, *, n_boot=400, level=0.9, method="wishart",
                       axis_mismatch=0.0, bands_per_decade=16, min_bins=4, seed=None):
    """Run a simulation through the same spectra and estimator as real data.

    Returns ``(estimate, truth, matrices)``: the
    :class:`bayescal.core.selfnoise.sleeman.SelfNoise`, the (3, B) true band
    self-noise and the (B, 3, 3) acceleration matrices. ``band`` defaults to
    0.01 Hz up to 0.8 of Nyquist.
    """
    from ..core.selfnoise import acceleration_band_matrices, estimate_self_noise
    from ..core.spectra import band_dof, cross_spectra

    n = sim.data.shape[1]
    band = band or (0.01, 0.4 * sim.fs)
    sp = cross_spectra(sim.data, np.empty((0, n)), sim.fs, sim.response_fn(), None, band,
                       bands_per_decade=bands_per_decade, min_bins=min_bins)
    C, fc = acceleration_band_matrices(sp)
    dof = band_dof(sp)
    est = estimate_self_noise(C, dof, fc, level=level, n_boot=n_boot,
                              seed=sim.seed if seed is None else seed,
                              per_segment=sp.per_segment, method=method,
                              axis_mismatch=axis_mismatch)
    return est, true_band_noise(sp), C
