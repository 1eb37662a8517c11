"""Synthetic co-located recordings with known truth.

Ground motion is a stationary Gaussian field built in the frequency domain: a
microseism-shaped velocity spectrum carried by Rayleigh and Love plane waves
from several directions plus a weaker diffuse part (so the 3x3 ground
cross-spectrum has full rank). Each channel sees ``v . g`` through its *true*
response plus its own noise, referred to the ground and scaled to a chosen
coherence; the *metadata* (StationXML) hold the nominal values. Everything is
periodic (made with the inverse FFT), so responses apply exactly, with no
edge effects.

Switches reproduce the effects a calibration model can leave out (see the
model-criticism issue): ``timing_offset_s``, ``clock_drift_ppm``,
``extra_pole`` (sensor, corner Hz), ``polarity_reversal`` (channel index),
``channel_swap`` (two indices), ``tilt_noise`` (relative level).

``ground`` chooses another family of ground spectra (:mod:`.ground`: a
steep fall below the microseism, peaks from several directions with Love
waves, a three-dimensional background).

Self-noise regimes (what real huddles vary): ``coherence`` and
``ref_coherence`` set each sensor's own noise, so the reference can be as
noisy as the SUT or noisier; with ``noise_in_counts=True`` each channel's
self-noise is white in counts (as a digitizer's or a sensor's electronics
noise is) and the same on all three channels of a sensor, scaled to that
coherence at ``NOISE_REFERENCE_HZ`` on an axis of mean ground power, so
referred to the ground it rises below the sensor's corner instead of
following the signal. (By default each channel's noise is a fixed share of
its own signal: convenient for coverage studies, unlike real self-noise.) Metadata a few per cent off: give ``sut_response`` gains that differ
from ``nominal_response``'s.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from obspy import Inventory, Stream, Trace, UTCDateTime
from obspy.core.inventory import Channel, Network, Site, Station
from obspy.core.inventory.response import (CoefficientsTypeResponseStage, InstrumentSensitivity,
                                           PolesZerosResponseStage, Response)

from ..core.orientation import unit_vector
from ..core.response import normalization_factor, paz_velocity_response, pendulum_poles
from .ground import ground_family

DIGITIZER_GAIN = 4.0e5   # counts per volt
NORM_FREQ = 1.0          # Hz
#: Frequency (Hz) at which self-noise white in counts has the asked coherence.
NOISE_REFERENCE_HZ = 0.2


def band_code(fs):
    """SEED band code of a broadband sensor (corner period 10 s or longer)
    at sampling rate ``fs`` Hz, as the SEED manual's Appendix A gives it:
    F from 1000 Hz, C from 250, H from 80, B from 10, M above 1 and below
    10, L about 1 (0.5 to 1), V about 0.1 (0.05 to 0.5), U below."""
    for code, lowest in (("F", 1000.0), ("C", 250.0), ("H", 80.0), ("B", 10.0)):
        if fs >= lowest:
            return code
    return "M" if fs > 1.0 else "L" if fs >= 0.5 else "V" if fs >= 0.05 else "U"


def ground_spectrum(f):
    """Velocity PSD shape (arbitrary units): primary and secondary microseism
    peaks over a background; zero at f = 0."""
    f = np.asarray(f, float)
    with np.errstate(divide="ignore"):
        lf = np.log(np.where(f > 0, f, 1.0))
        s = (np.exp(-((lf - np.log(0.18)) / 0.35) ** 2)
             + 0.3 * np.exp(-((lf - np.log(0.07)) / 0.3) ** 2)
             + 0.02 * 0.1 / np.where(f > 0, f, 1.0) + 0.01)
    return np.where(f > 0, s, 0.0)


def velocity_response(period_s, damping, gain, norm_freq=NORM_FREQ, digitizer_gain=DIGITIZER_GAIN,
                      sample_rate=20.0, input_units="M/S", extra_poles=()):
    """ObsPy ``Response`` of a broadband: two pendulum poles, two zeros at 0,
    ``extra_poles`` (rad/s, each conjugate listed), gain ``gain`` (V per m/s)
    at ``norm_freq``, a flat digitizer of ``digitizer_gain`` counts per volt.
    The pendulum stage is normalised to 1 at ``norm_freq``
    (:func:`bayescal.core.response.normalization_factor`)."""
    poles = list(pendulum_poles(period_s, damping)) + list(extra_poles)
    a0 = normalization_factor([0j, 0j], poles, norm_freq)
    st1 = PolesZerosResponseStage(
        stage_sequence_number=1, stage_gain=gain, stage_gain_frequency=norm_freq,
        input_units=input_units, output_units="V", pz_transfer_function_type="LAPLACE (RADIANS/SECOND)",
        normalization_frequency=norm_freq, zeros=[0j, 0j], poles=poles, normalization_factor=a0)
    st2 = CoefficientsTypeResponseStage(
        stage_sequence_number=2, stage_gain=digitizer_gain, stage_gain_frequency=norm_freq,
        input_units="V", output_units="COUNTS", cf_transfer_function_type="DIGITAL",
        numerator=[1.0], denominator=[], decimation_input_sample_rate=sample_rate,
        decimation_factor=1, decimation_offset=0, decimation_delay=0.0, decimation_correction=0.0)
    sens = InstrumentSensitivity(value=gain * digitizer_gain, frequency=norm_freq,
                                 input_units=input_units, output_units="COUNTS")
    return Response(instrument_sensitivity=sens, response_stages=[st1, st2])


@dataclass
class SimulatedPair:
    """A simulated recording pair and its truth."""

    sut: Stream
    ref: Stream
    sut_inventory: Inventory
    ref_inventory: Inventory
    truth: dict = field(default_factory=dict)

    def write(self, folder):
        """Write ``sut.mseed``, ``ref.mseed``, ``sut.xml``, ``ref.xml`` and
        ``truth.json`` into ``folder``; returns the paths."""
        import json
        import os
        os.makedirs(folder, exist_ok=True)
        paths = {k: os.path.join(folder, k) for k in
                 ("sut.mseed", "ref.mseed", "sut.xml", "ref.xml", "truth.json")}
        self.sut.write(paths["sut.mseed"], format="MSEED", encoding="FLOAT64")
        self.ref.write(paths["ref.mseed"], format="MSEED", encoding="FLOAT64")
        self.sut_inventory.write(paths["sut.xml"], format="STATIONXML")
        self.ref_inventory.write(paths["ref.xml"], format="STATIONXML")
        with open(paths["truth.json"], "w") as fh:
            json.dump(self.truth, fh, indent=2)
        return paths


def _plane_waves(rng, freqs, n_waves, diffuse, wave_seed=None):
    """(3, F) complex ground-velocity spectrum (NED) and its expected
    cross-spectral matrix (F, 3, 3) up to the common PSD scale. The waves'
    directions, weights and kinds come from ``rng`` between its per-bin
    draws, so they change with the record's length; with ``wave_seed`` they
    come from a generator of their own, the same at any length."""
    prng = rng if wave_seed is None else np.random.default_rng([wave_seed, 99])
    amp = np.sqrt(ground_spectrum(freqs) / 2.0)
    g = np.zeros((3, freqs.size), complex)
    expected = np.zeros((freqs.size, 3, 3), complex)
    for _ in range(n_waves):
        phi = prng.uniform(0, 2 * np.pi)
        w = prng.uniform(0.4, 1.0)
        c = w * amp * (rng.standard_normal(freqs.size) + 1j * rng.standard_normal(freqs.size))
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        if prng.uniform() < 0.7:   # Rayleigh: vertical (up) 90 degrees from radial
            pol = radial + np.array([0, 0, -1.0]) * 0.8j
        else:                      # Love: transverse
            pol = np.array([-np.sin(phi), np.cos(phi), 0.0]).astype(complex)
        g += pol[:, None] * c[None, :]
        expected += (2 * w * w * amp ** 2)[:, None, None] * np.outer(pol, pol.conj())[None]
    for k in range(3):
        c = diffuse * amp * (rng.standard_normal(freqs.size) + 1j * rng.standard_normal(freqs.size))
        g[k] += c
        expected[:, k, k] += 2 * diffuse ** 2 * amp ** 2
    return g, expected


def _noise_like(rng, freqs, signal_psd, coherence, resp=None):
    """Complex ground-referred noise with PSD ``signal_psd * (1 - coh) / coh``;
    with ``resp`` (the channel's response), white in counts instead, at the
    level that gives coherence ``coh`` at :data:`NOISE_REFERENCE_HZ`."""
    psd = signal_psd * (1.0 - coherence) / coherence
    if resp is not None:
        k = np.argmin(np.abs(freqs - NOISE_REFERENCE_HZ))
        counts = psd[k] * np.abs(resp[k]) ** 2
        with np.errstate(divide="ignore"):
            psd = np.where(np.abs(resp) > 0, counts / np.abs(resp) ** 2, 0.0)
    level = np.sqrt(psd / 2.0)
    return level * (rng.standard_normal(freqs.size) + 1j * rng.standard_normal(freqs.size))


def _drifting(spectrum, n, fs, ppm, chunk_s=10.0):
    """Samples of ``spectrum`` (channels, n//2+1) delayed by ``ppm * 1e-6 * t``
    (a clock that gains ``ppm``: its time stamps run ahead, so the record
    shows each arrival later and later): each ``chunk_s`` stretch is cut from the
    record delayed exactly (a Fourier phase) by the delay at its centre, so
    the delay is off by at most ``ppm * 1e-6 * chunk_s / 2`` (0.5 ms at
    100 ppm). Linear interpolation of the samples would low-pass the
    record as well (to 0.6 of the amplitude at 0.3 of the sampling rate
    for half-sample delays), a loss no real clock causes."""
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    chunk_s = max(chunk_s, n / fs / 400.0)       # at most 400 inverse FFTs of the record
    step = max(1, int(round(chunk_s * fs)))
    out = np.empty((spectrum.shape[0], n))
    for a in range(0, n, step):
        tau = ppm * 1e-6 * (a + min(step, n - a) / 2.0) / fs
        y = np.fft.irfft(spectrum * np.exp(-2j * np.pi * freqs * tau)[None, :], n=n, axis=1)
        out[:, a:a + step] = y[:, a:a + step]
    return out


def simulate_pair(*, duration=7200.0, fs=20.0, seed=0, coherence=0.99, ref_coherence=0.9999,
                  sut_azimuth=(0.0, 90.0, 0.0), sut_dip=(0.0, 0.0, -90.0),
                  nominal_azimuth=(0.0, 90.0, 0.0), nominal_dip=(0.0, 0.0, -90.0),
                  sut_response=((30.0, 0.707, 750.0),) * 3, nominal_response=(30.0, 0.707, 750.0),
                  ref_response=(120.0, 0.707, 1500.0), n_waves=6, diffuse=0.3,
                  timing_offset_s=0.0, clock_drift_ppm=0.0, extra_pole=None,
                  polarity_reversal=None, channel_swap=None, tilt_noise=0.0,
                  noise_in_counts=False, network="XX", station="SIM", start=UTCDateTime(2026, 1, 1),
                  wave_seed=None, ground=None):
    """Simulate a SUT/reference pair; see the module docstring.

    Angles in SEED degrees, responses as (period_s, damping, gain in V per
    m/s); ``sut_response`` per SUT channel is the truth, ``nominal_response``
    what the StationXML says. ``coherence`` is the squared coherence of each
    SUT channel with the true ground motion (its self-noise), likewise
    ``ref_coherence`` for the reference channels. ``wave_seed``: the plane
    waves' directions, weights and kinds from a generator of their own, so
    records of any length share one ground field and one noise level
    (by default they come from ``seed``'s generator between the per-bin
    draws: one seed at two durations is two ground fields). ``ground``: a
    family of ground spectra (:mod:`.ground`), None for the plane waves above.
    """
    rng, n = np.random.default_rng(seed), int(round(duration * fs))
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    g, expected = _ground(rng, freqs, n_waves, diffuse, wave_seed, ground)
    v_sut = unit_vector(sut_azimuth, sut_dip)
    ref_az, ref_dip = (0.0, 90.0, 0.0), (0.0, 0.0, -90.0)
    v_ref = unit_vector(ref_az, ref_dip)
    pole_sut, pole_ref = _extra_poles(extra_pole)
    field_ = (rng, freqs, g, expected)
    xs = _record(*field_, v_sut, sut_response, coherence=coherence, extra=pole_sut,
                 noise_in_counts=noise_in_counts)
    xr = _record(*field_, v_ref, [ref_response] * 3, coherence=ref_coherence, extra=pole_ref,
                 noise_in_counts=noise_in_counts)
    if tilt_noise:
        _add_tilt_noise(xs, rng, freqs, expected, v_sut, sut_response, tilt_noise)
    sut_t = _sut_samples(xs, freqs, n, fs, timing_offset_s=timing_offset_s,
                         clock_drift_ppm=clock_drift_ppm, polarity_reversal=polarity_reversal,
                         channel_swap=channel_swap)
    ref_t = np.fft.irfft(xr, n=n, axis=1)

    bc = band_code(fs)
    sut_codes = [f"{bc}H1", f"{bc}H2", f"{bc}HZ"]
    ref_codes = [f"{bc}HN", f"{bc}HE", f"{bc}HZ"]
    where = dict(network=network, station=station, fs=fs, start=start)
    truth = {"channels": _truth_channels(f"{network}.{station}.10.", sut_codes, sut_azimuth,
                                         sut_dip, sut_response),
             "coherence": coherence, "ref_coherence": ref_coherence, "seed": seed,
             "noise_in_counts": noise_in_counts,
             "effects": {"timing_offset_s": timing_offset_s, "clock_drift_ppm": clock_drift_ppm,
                         "extra_pole": extra_pole, "polarity_reversal": polarity_reversal,
                         "channel_swap": channel_swap, "tilt_noise": tilt_noise}}
    truth.update({} if wave_seed is None else {"wave_seed": wave_seed},
                 **({} if ground_family(ground) is None else {"ground": ground_family(ground).name}))
    return SimulatedPair(
        sut=_stream(sut_t, "10", sut_codes, **where), ref=_stream(ref_t, "00", ref_codes, **where),
        sut_inventory=_inventory("10", sut_codes, nominal_azimuth, nominal_dip, nominal_response,
                                 **where),
        ref_inventory=_inventory("00", ref_codes, ref_az, ref_dip, ref_response, **where),
        truth=truth)


def _ground(rng, freqs, n_waves, diffuse, wave_seed, ground):
    """The ground field and its expected cross-spectra: the default plane
    waves (:func:`_plane_waves`) or the family ``ground`` names."""
    family = ground_family(ground)
    if family is None:
        return _plane_waves(rng, freqs, n_waves, diffuse, wave_seed)
    return family.draw(rng, freqs, wave_seed)


def _extra_poles(extra_pole):
    """``(SUT's, reference's)`` extra pole (rad/s, or None) of ``extra_pole``
    = ``(which, corner Hz)``."""
    if extra_pole is None:
        return None, None
    which, fc = extra_pole
    p = -2 * np.pi * float(fc)
    return (p, None) if which == "sut" else (None, p)


def _truth_channels(prefix, codes, azimuth, dip, response):
    """The true orientation and response of each SUT channel, by its id."""
    return {f"{prefix}{c}": {"azimuth_deg": float(a) % 360.0, "dip_deg": float(d),
                             "period_s": r[0], "damping": r[1], "gain": r[2]}
            for c, a, d, r in zip(codes, azimuth, dip, response)}


def _record(rng, freqs, g, expected, vectors, responses, *, coherence, extra, noise_in_counts):
    """Spectra (counts) of the channels along ``vectors``: the ground motion
    ``g`` plus self-noise at squared coherence ``coherence``, through each
    channel's response (an extra pole ``extra`` rad/s when not None)."""
    # self-noise white in counts is the same on every channel of a sensor
    # (its electronics), at the level that gives the asked coherence on an
    # axis with the mean power of the three ground components
    mean_psd = np.real(np.einsum("fii->f", expected)) / 3.0
    out = []
    for k, v in enumerate(vectors):
        sig = v @ g
        psd = mean_psd if noise_in_counts else np.real(np.einsum("i,fij,j->f", v, expected, v))
        t0, h, gain = responses[k]
        poles = () if extra is None else (extra,)
        resp = paz_velocity_response(freqs, t0, h, gain, extra_poles=poles,
                                     digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)
        ground = sig + _noise_like(rng, freqs, psd, coherence, resp if noise_in_counts else None)
        out.append(ground * resp)
    return np.array(out)


def _add_tilt_noise(xs, rng, freqs, expected, v_sut, sut_response, tilt_noise):
    """Add red (tilt) noise to the SUT's two horizontal spectra ``xs`` in place."""
    red = np.where(freqs > 0, (0.02 / np.maximum(freqs, 1e-9)) ** 2, 0.0)
    for k in range(2):
        psd = np.real(np.einsum("i,fij,j->f", v_sut[k], expected, v_sut[k]))
        lvl = np.sqrt(tilt_noise * red * np.median(psd) / 2)
        xs[k] += lvl * (rng.standard_normal(freqs.size) + 1j * rng.standard_normal(freqs.size)) \
            * paz_velocity_response(freqs, *sut_response[k], digitizer_gain=DIGITIZER_GAIN)


def _sut_samples(xs, freqs, n, fs, *, timing_offset_s, clock_drift_ppm, polarity_reversal,
                 channel_swap):
    """The SUT's samples from its spectra ``xs``, with the timing, clock,
    polarity and wiring effects asked for."""
    if timing_offset_s:
        xs = xs * np.exp(-2j * np.pi * freqs * timing_offset_s)[None, :]
    sut_t = np.fft.irfft(xs, n=n, axis=1)
    if clock_drift_ppm:
        sut_t = _drifting(xs, n, fs, clock_drift_ppm)
    if polarity_reversal is not None:
        sut_t[polarity_reversal] *= -1
    if channel_swap is not None:
        i, j = channel_swap
        sut_t[[i, j]] = sut_t[[j, i]]
    return sut_t


def _stream(data, loc, codes, *, network, station, fs, start):
    """One sensor's traces."""
    return Stream([Trace(data=np.ascontiguousarray(x), header={
        "network": network, "station": station, "location": loc, "channel": c,
        "sampling_rate": fs, "starttime": start}) for x, c in zip(data, codes)])


def _inventory(loc, codes, az, dip, resp, *, network, station, fs, start):
    """One sensor's StationXML: its channels' orientations and one response."""
    chans = [Channel(code=c, location_code=loc, latitude=0.0, longitude=0.0, elevation=0.0,
                     depth=0.0, azimuth=float(a) % 360.0, dip=float(d), sample_rate=fs,
                     start_date=start - 86400,
                     response=velocity_response(*resp, sample_rate=fs))
             for c, a, d in zip(codes, az, dip)]
    sta = Station(code=station, latitude=0.0, longitude=0.0, elevation=0.0, channels=chans,
                  site=Site(name="bayescal simulation"), start_date=start - 86400)
    return Inventory(networks=[Network(code=network, stations=[sta])], source="bayescal.simulate")


def self_noise_psd(freqs, *, duration=7200.0, fs=20.0, seed=0, coherence=0.99,
                   ref_coherence=0.9999, sut_azimuth=(0.0, 90.0, 0.0), sut_dip=(0.0, 0.0, -90.0),
                   sut_response=((30.0, 0.707, 750.0),) * 3, ref_response=(120.0, 0.707, 1500.0),
                   n_waves=6, diffuse=0.3, noise_in_counts=False, wave_seed=None, ground=None,
                   **_ignored):
    """The true self-noise of every channel of :func:`simulate_pair` called
    with the same arguments: ``(sut, ref)``, each (3, len(freqs)) one-sided
    velocity PSD in (m/s)^2/Hz at ``freqs`` (Hz), interpolated from the
    simulation's frequency grid. (The noise of a bin ``N_f`` has
    ``E|N_f|^2 = psd``; the inverse FFT of ``n`` samples at ``fs`` makes that
    a one-sided PSD ``2 psd / (n fs)``.)"""
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    grid = np.fft.rfftfreq(n, 1.0 / fs)
    _, expected = _ground(rng, grid, n_waves, diffuse, wave_seed, ground)
    mean_psd = np.real(np.einsum("fii->f", expected)) / 3.0
    k = np.argmin(np.abs(grid - NOISE_REFERENCE_HZ))

    def side(vectors, responses, coh):
        out = []
        for v, (t0, h, gain) in zip(vectors, responses):
            if noise_in_counts:
                resp = np.abs(paz_velocity_response(grid, t0, h, gain, digitizer_gain=DIGITIZER_GAIN,
                                                    norm_freq=NORM_FREQ)) ** 2
                psd = mean_psd[k] * (1 - coh) / coh * resp[k] / np.where(resp > 0, resp, np.inf)
            else:
                psd = np.real(np.einsum("i,fij,j->f", v, expected, v)) * (1 - coh) / coh
            out.append(np.interp(freqs, grid, 2.0 * psd / (n * fs)))
        return np.array(out)

    v_ref = unit_vector((0.0, 90.0, 0.0), (0.0, 0.0, -90.0))
    return (side(unit_vector(sut_azimuth, sut_dip), sut_response, coherence),
            side(v_ref, [ref_response] * 3, ref_coherence))
