"""Simulator: a random (PRBS), step or sine coil calibration run of one
ordinary channel, with known long-period pair, gain and high-frequency poles.

The coil makes an equivalent ground acceleration ``C u(t)`` (``u`` the PRBS,
steps or sine driving the coil, counts). The sensor adds its own
equivalent-acceleration self-noise (``noise_ratio`` of the calibration
signal's rms; white, or coloured with power spectral density proportional to
``f ** -noise_slope``), and the digitizer white noise in counts:

    X(f) = H(f) (C U(f) + N(f)) / (2 pi i f) + digitizer noise.

The input channel records ``u`` plus white noise of rms ``input_noise`` times
the drive's amplitude (0: recorded exactly). A fit that takes the recorded
input for the drive sees the transfer ``S_yx / S_xx`` attenuated by
``S_uu / (S_uu + S_nn)``, that is the gain low by ``input_noise ** 2`` (for
a PRBS, whose power is the amplitude squared at every frequency).

with ``H`` the *true* velocity response built by
:func:`bayescal.core.response.family.paz_velocity_response` (pendulum pair, two zeros
at the origin, the high-frequency poles), applied exactly through the FFT of a
periodic record. The StationXML holds the *nominal* response, the same form
with nominal values (:func:`paz_response`), built independently via ObsPy.
"""
from __future__ import annotations

import numpy as np
from obspy import Inventory, Stream, Trace, UTCDateTime
from obspy.core.inventory import Channel, Network, Site, Station

from ..core.response import paz_velocity_response
from .coil import CalibrationSimulation, coloured_rfft, prbs
from .pair import DIGITIZER_GAIN, NORM_FREQ, band_code, velocity_response

#: Nominal STS-2-like channel: period (s), damping, gain (V per m/s).
LP_NOMINAL = (120.0, 0.707, 1500.0)
#: Nominal high-frequency poles (rad/s): a pair at 50 Hz (damping 0.6) and a
#: real pole at 70 Hz, within a 200 Hz record's band.
HF_NOMINAL = (2 * np.pi * 50.0 * (-0.6 + 0.8j), -2 * np.pi * 70.0)


def _expand(poles):
    """Poles with Im >= 0 and their conjugates (real ones once)."""
    out = []
    for p in poles:
        p = complex(p)
        out += [p, p.conjugate()] if abs(p.imag) > 0 else [p]
    return out


def paz_response(period_s, damping, gain, hf_poles=(), sample_rate=20.0, norm_freq=NORM_FREQ):
    """ObsPy ``Response``: pendulum pair, two zeros at 0, ``hf_poles`` (Im >= 0,
    conjugates added), gain at ``norm_freq``, a flat digitizer
    (:func:`bayescal.simulate.pair.velocity_response`)."""
    return velocity_response(period_s, damping, gain, norm_freq=norm_freq,
                             sample_rate=sample_rate, extra_poles=_expand(hf_poles))


def simulate_random_cal(*, truth=LP_NOMINAL, hf_true=(), nominal=LP_NOMINAL, hf_nominal=(),
                        duration=3 * 3600.0, fs=20.0, coil_constant=1e-9, amplitude=1e5,
                        clock_samples=1, noise_ratio=0.05, digitizer_noise=1.0, seed=0,
                        noise_slope=0.0, input_noise=0.0, **header):
    """One random calibration run of a vertical channel (see module docstring).

    ``truth``/``nominal``: (period_s, damping, gain V per m/s); ``hf_true`` /
    ``hf_nominal``: high-frequency poles (rad/s, Im >= 0), same count and order.
    ``noise_slope``, ``input_noise``: the self-noise's colour and the input
    channel's own noise (module docstring). ``header``: ``input_channel``,
    ``network``, ``station``, ``location``, ``start``. Returns a
    :class:`CalibrationSimulation` with ``runs["cal"]``.
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    u = amplitude * prbs(n, clock_samples, seed=int(rng.integers(1 << 30)))
    return _simulate(u, "random", rng, truth=truth, hf_true=hf_true, nominal=nominal,
                     hf_nominal=hf_nominal, fs=fs, coil_constant=coil_constant,
                     noise_std=noise_ratio * coil_constant * amplitude,
                     digitizer_noise=digitizer_noise, noise_slope=noise_slope,
                     input_noise=input_noise,
                     extra={"noise_ratio": noise_ratio, "seed": seed}, **header)


def simulate_step_cal(*, truth=LP_NOMINAL, nominal=LP_NOMINAL, duration=1800.0, fs=20.0,
                      steps=((120.0, 1.0), (900.0, 0.0)), coil_constant=1e-9, amplitude=1e5,
                      noise_ratio=0.05, digitizer_noise=1.0, seed=0, noise_slope=0.0,
                      input_noise=0.0, **header):
    """One step calibration run: the input is 0 counts, then ``amplitude``
    times each level of ``steps`` ((time s, level), ...) from that time on.
    The sensor's white equivalent-acceleration self-noise has rms
    ``noise_ratio`` times the step's acceleration ``C amplitude``. The
    record should end at rest long enough for the response to decay (it is
    built periodically)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    u = np.zeros(n)
    for t0, level in steps:
        u[t >= t0] = amplitude * level
    return _simulate(u, "step", rng, truth=truth, hf_true=(), nominal=nominal, hf_nominal=(),
                     fs=fs, coil_constant=coil_constant,
                     noise_std=noise_ratio * coil_constant * amplitude,
                     digitizer_noise=digitizer_noise, noise_slope=noise_slope,
                     input_noise=input_noise,
                     extra={"noise_ratio": noise_ratio, "seed": seed,
                            "steps": [list(s) for s in steps]}, **header)


def simulate_sine_cal(freq, *, truth=LP_NOMINAL, hf_true=(), nominal=LP_NOMINAL, hf_nominal=(),
                      duration=900.0, fs=20.0, coil_constant=1e-9, amplitude=1e5,
                      noise_ratio=0.05, digitizer_noise=1.0, seed=0, noise_slope=0.0,
                      input_noise=0.0, **header):
    """One sine calibration run at ``freq`` Hz (rounded to a whole number of
    cycles in the record, so the periodic construction is the steady state
    of a sine running before the record). Self-noise rms ``noise_ratio``
    times the sine's acceleration amplitude. ``truth["sine_freq_hz"]`` is
    the frequency used and ``truth["response"]`` the true response there
    (counts per m/s, real and imaginary part)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    f0 = max(1, round(freq * n / fs)) * fs / n
    phase = rng.uniform(0, 2 * np.pi)
    u = amplitude * np.sin(2 * np.pi * f0 * np.arange(n) / fs + phase)
    h0 = paz_velocity_response([f0], *truth, extra_poles=_expand(hf_true),
                               digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)[0]
    return _simulate(u, "sine", rng, truth=truth, hf_true=hf_true, nominal=nominal,
                     hf_nominal=hf_nominal, fs=fs, coil_constant=coil_constant,
                     noise_std=noise_ratio * coil_constant * amplitude,
                     digitizer_noise=digitizer_noise, noise_slope=noise_slope,
                     input_noise=input_noise,
                     extra={"noise_ratio": noise_ratio, "seed": seed, "sine_freq_hz": f0,
                            "response": [h0.real, h0.imag]}, **header)


def _simulate(u, kind, rng, *, truth, hf_true, nominal, hf_nominal, fs, coil_constant, noise_std,
              digitizer_noise, noise_slope, input_noise, extra, input_channel="BC0",
              network="XX", station="CAL", location="00", start=UTCDateTime(2026, 1, 1)):
    """Output of a channel with the true response to ``C u`` plus self-noise
    (std ``noise_std`` m/s^2, PSD proportional to ``f ** -noise_slope``) and
    digitizer noise; the input channel ``u`` plus white noise of std
    ``input_noise`` times ``max |u|``; Stream, StationXML."""
    n = u.size
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    iw = 2j * np.pi * freqs
    iw[0] = np.inf
    k = paz_velocity_response(freqs, *truth, extra_poles=_expand(hf_true),
                              digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)
    a_f = np.fft.rfft(coil_constant * u)
    noise = coloured_rfft(rng, freqs, noise_std, n, noise_slope)
    x = np.fft.irfft(k * (a_f + noise) / iw, n=n) + digitizer_noise * rng.standard_normal(n)
    if input_noise > 0:
        u = u + input_noise * np.max(np.abs(u)) * rng.standard_normal(n)
    code = f"{band_code(fs)}HZ"
    hdr = dict(network=network, station=station, location=location, sampling_rate=fs,
               starttime=start)
    st = Stream([Trace(data=u.astype(np.float64), header=dict(hdr, channel=input_channel)),
                 Trace(data=np.ascontiguousarray(x), header=dict(hdr, channel=code))])
    ch = Channel(code=code, location_code=location, latitude=0.0, longitude=0.0, elevation=0.0,
                 depth=0.0, azimuth=0.0, dip=-90.0, sample_rate=fs, start_date=start - 86400,
                 response=paz_response(*nominal, hf_poles=hf_nominal, sample_rate=fs))
    sta = Station(code=station, latitude=0.0, longitude=0.0, elevation=0.0, channels=[ch],
                  site=Site(name=f"bayescal {kind} calibration simulation"),
                  start_date=start - 86400)
    inv = Inventory(networks=[Network(code=network, stations=[sta])],
                    source="bayescal.simulate.cal")
    truth_d = {"period_s": truth[0], "damping": truth[1], "gain": truth[2],
               "hf_poles": [[complex(p).real, complex(p).imag] for p in hf_true],
               "nominal": {"period_s": nominal[0], "damping": nominal[1], "gain": nominal[2],
                           "hf_poles": [[complex(p).real, complex(p).imag] for p in hf_nominal]},
               "coil_constant": coil_constant, "duration_s": n / fs,
               "sampling_rate": fs, "channel": f"{network}.{station}.{location}.{code}",
               "input_channel": input_channel, "kind": kind, "noise_slope": noise_slope,
               "input_noise": input_noise, **extra}
    return CalibrationSimulation(runs={"cal": st}, inventory=inv, truth=truth_d)
