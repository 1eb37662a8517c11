"""Simulator, calibration mode: coil-by-coil runs of a symmetric triaxial
(STS-2-like) sensor with known element responses.

Run ``n`` drives element ``n``'s calibration coil with a pseudo-random binary
sequence ``u(t)`` (digitizer counts, recorded on the input channel, ``BC0`` by
default). The coil makes an equivalent ground acceleration ``a = C u`` along
the element's axis (``C`` the coil constant, m/s^2 per count). Every element
also carries its own self-noise (white equivalent acceleration), so the
outputs are

    element m:  E_m(f) = k_m(f) (delta_mn a(f) + n_m(f)) / (2 pi i f)
    XYZ output: X_c(f) = sum_m M[m, c] E_m(f) + digitizer noise,

with ``k_m`` the element's true velocity response (counts per m/s, from
:func:`bayescal.core.response.family.paz_velocity_response`) and ``M`` the UVW matrix
(rows U, V, W over columns X, Y, Z). With ``outputs="uvw"`` the sensor is in
UVW mode and the outputs are the ``E_m`` themselves. Signals are built
periodically with the inverse FFT, so responses apply exactly. The StationXML
holds the *nominal* responses (:func:`bayescal.simulate.velocity_response`).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np
from obspy import Inventory, Stream, Trace, UTCDateTime
from obspy.core.inventory import Channel, Network, Site, Station
from scipy.signal import max_len_seq

from ..core.orientation import STS2_UVW, azimuth_dip
from ..core.response import paz_velocity_response
from .pair import DIGITIZER_GAIN, NORM_FREQ, band_code, velocity_response

ELEMENTS = ("U", "V", "W")
#: Nominal STS-2-like element: natural period (s), damping, gain (V per m/s).
STS2_NOMINAL = (120.0, 0.707, 1500.0)


def prbs(n, clock_samples=1, seed=0):
    """Pseudo-random binary sequence of +-1, ``n`` samples, each bit held for
    ``clock_samples`` samples: a maximal-length sequence (period at least the
    record) started from a seeded non-zero register state."""
    bits_needed = int(np.ceil(n / clock_samples))
    nbits = max(4, int(np.ceil(np.log2(bits_needed + 1))))
    state = np.random.default_rng(seed).integers(0, 2, nbits)
    state[0] = 1
    seq = max_len_seq(nbits, state=state)[0][:bits_needed]
    return np.repeat(2.0 * seq - 1.0, clock_samples)[:n]


@dataclass
class CalibrationSimulation:
    """Simulated coil-by-coil runs and their truth.

    ``runs`` maps the driven element (``"U"``, ``"V"``, ``"W"``) to an ObsPy
    Stream holding the input channel and the sensor's outputs; ``inventory``
    is the SUT StationXML (outputs only, nominal responses).
    """

    runs: dict
    inventory: Inventory
    truth: dict = field(default_factory=dict)

    def write(self, folder):
        """Write ``cal_U.mseed``, ``cal_V.mseed``, ``cal_W.mseed``,
        ``sut.xml`` and ``truth.json`` into ``folder``; returns the paths."""
        os.makedirs(folder, exist_ok=True)
        paths = {}
        for name, st in self.runs.items():
            paths[name] = os.path.join(folder, f"cal_{name}.mseed")
            st.write(paths[name], format="MSEED", encoding="FLOAT64")
        paths["xml"] = os.path.join(folder, "sut.xml")
        self.inventory.write(paths["xml"], format="STATIONXML")
        paths["truth"] = os.path.join(folder, "truth.json")
        with open(paths["truth"], "w") as fh:
            json.dump(self.truth, fh, indent=2)
        return paths


def white_rfft(rng, nf, std_time, n):
    """Complex rfft coefficients of white noise with time-domain ``std_time``."""
    scale = std_time * np.sqrt(n / 2.0)
    out = scale * (rng.standard_normal(nf) + 1j * rng.standard_normal(nf))
    out[0] = 0.0
    return out


def coloured_rfft(rng, freqs, std_time, n, slope=0.0):
    """Complex rfft coefficients of noise with time-domain ``std_time`` and
    power spectral density proportional to ``freqs ** -slope`` (``slope`` 0:
    :func:`white_rfft`, the same draws)."""
    out = white_rfft(rng, freqs.size, std_time, n)
    if slope:
        shape = np.zeros(freqs.size)
        shape[1:] = (freqs[1:] / freqs[1]) ** (-0.5 * slope)
        out *= shape / np.sqrt(np.mean(shape[1:] ** 2))
    return out


def simulate_calibration(*, elements=(STS2_NOMINAL,) * 3, nominal=STS2_NOMINAL, matrix=STS2_UVW,
                         duration=8 * 3600.0, fs=1.0, coil_constant=1e-9, amplitude=1e5,
                         clock_samples=1, noise_ratio=0.05, digitizer_noise=1.0, outputs="xyz",
                         input_channel="BC0", seed=0, network="XX", station="UVW",
                         location="00", start=UTCDateTime(2026, 1, 1)):
    """Coil-by-coil calibration runs of a UVW sensor (see module docstring).

    Parameters
    ----------
    elements : per element U, V, W its true (period_s, damping, gain V per m/s).
    nominal : the (period_s, damping, gain) written to the StationXML.
    matrix : UVW matrix, rows U, V, W over columns X, Y, Z.
    coil_constant : m/s^2 of equivalent ground acceleration per input count.
    amplitude : PRBS amplitude in counts.
    noise_ratio : each element's self-noise (white equivalent acceleration)
        as a fraction of the calibration acceleration's rms.
    digitizer_noise : white noise rms added to every output, counts.
    outputs : ``"xyz"`` (channels 1, 2, Z) or ``"uvw"`` (channels U, V, W).
    """
    rng = np.random.default_rng(seed)
    m = np.asarray(matrix, float)
    n = int(round(duration * fs))
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    iw = 2j * np.pi * freqs
    iw[0] = np.inf                                   # no DC in velocity
    codes, mix = _outputs(outputs, band_code(fs), m)
    k = np.array([paz_velocity_response(freqs, *el, digitizer_gain=DIGITIZER_GAIN,
                                        norm_freq=NORM_FREQ) for el in elements])
    runs = {}
    t_run = start
    for idx, name in enumerate(ELEMENTS):
        u = amplitude * prbs(n, clock_samples, seed=int(rng.integers(1 << 30)))
        a_f = np.fft.rfft(coil_constant * u)
        a_rms = coil_constant * amplitude
        drive = np.zeros((3, freqs.size), complex)
        drive[idx] = a_f
        noise = np.array([white_rfft(rng, freqs.size, noise_ratio * a_rms, n) for _ in range(3)])
        elem = k * (drive + noise) / iw[None, :]                      # (3, F) counts
        out_f = mix.T @ elem
        out_t = np.fft.irfft(out_f, n=n, axis=1)
        out_t += digitizer_noise * rng.standard_normal(out_t.shape)
        runs[name] = _run_stream(u, out_t, [input_channel] + codes, network=network,
                                 station=station, location=location, fs=fs, start=t_run)
        t_run = t_run + duration + 600.0
    inventory = _inventory(codes, outputs, m, nominal, fs, network=network,
                           station=station, location=location, start=start)
    truth = {"elements": {nm: {"period_s": float(el[0]), "damping": float(el[1]),
                               "gain": float(el[2])} for nm, el in zip(ELEMENTS, elements)},
             "nominal": {"period_s": nominal[0], "damping": nominal[1], "gain": nominal[2]},
             "matrix": m.tolist(), "coil_constant": coil_constant, "amplitude": amplitude,
             "noise_ratio": noise_ratio, "digitizer_noise": digitizer_noise, "outputs": outputs,
             "duration_s": duration, "sampling_rate": fs, "seed": seed,
             "input_channel": input_channel}
    return CalibrationSimulation(runs=runs, inventory=inventory, truth=truth)


def _outputs(outputs, bc, matrix):
    """The output channels' codes and the matrix from elements to outputs."""
    if outputs == "xyz":
        return [f"{bc}H1", f"{bc}H2", f"{bc}HZ"], matrix
    if outputs == "uvw":
        return [f"{bc}HU", f"{bc}HV", f"{bc}HW"], np.eye(3)
    raise ValueError("outputs must be 'xyz' or 'uvw'")


def _run_stream(u, out_t, channels, *, network, station, location, fs, start):
    """One run's traces: the coil input ``u`` then the outputs ``out_t``."""
    traces = [Trace(data=u.astype(np.float64), header=dict(
        network=network, station=station, location=location, channel=channels[0],
        sampling_rate=fs, starttime=start))]
    for c, x in zip(channels[1:], out_t):
        traces.append(Trace(data=np.ascontiguousarray(x), header=dict(
            network=network, station=station, location=location, channel=c,
            sampling_rate=fs, starttime=start)))
    return Stream(traces)


def _inventory(codes, outputs, matrix, nominal, fs, *, network, station, location, start):
    if outputs == "xyz":
        angles = [(0.0, 0.0), (90.0, 0.0), (0.0, -90.0)]
    else:
        # sensor frame X=N, Y=E, Z=up  ->  NED (x, y, -z)
        ned = matrix * np.array([1.0, 1.0, -1.0])[None, :]
        az, dip = azimuth_dip(ned)
        angles = list(zip(az, dip))
    chans = [Channel(code=c, location_code=location, latitude=0.0, longitude=0.0, elevation=0.0,
                     depth=0.0, azimuth=float(a), dip=float(d), sample_rate=fs,
                     start_date=start - 86400,
                     response=velocity_response(*nominal, sample_rate=fs))
             for c, (a, d) in zip(codes, angles)]
    sta = Station(code=station, latitude=0.0, longitude=0.0, elevation=0.0, channels=chans,
                  site=Site(name="bayescal calibration simulation"), start_date=start - 86400)
    return Inventory(networks=[Network(code=network, stations=[sta])], source="bayescal.simulate.coil")
