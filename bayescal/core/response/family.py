"""Instrument responses: evaluation from ObsPy ``Response`` and the parametric
family (natural period T0, damping h, generator gain G) of a velocity sensor.

The parametric response of a channel is its complete nominal response with
the two long-period poles and the first-stage gain replaced:

    H(f; T0, h, G) = H_nom(f) * (G / G_nom) * |D(s_n; p)| / |D(s_n; p_nom)|
                     * D(s; p_nom) / D(s; p),

    D(s; p) = s^2 + 2 h w0 s + w0^2,   w0 = 2 pi / T0,   s = 2 pi i f,

where ``s_n`` is the first stage's normalisation frequency, so that G keeps
the meaning StationXML gives it: the first stage's gain (V per m/s for a
broadband) at the normalisation frequency. Every other pole, zero and stage
stays at its nominal value. All responses are returned as *velocity*
responses (counts per m/s) whatever the input units of the StationXML, so a
sensor whose response is given in acceleration is handled by ObsPy's unit
conversion rather than mis-scaled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .paz import transfer
from ...errors import ResponseError

#: Names of the response parameters, in the order used everywhere.
RESPONSE_PARAMS = ("period_s", "damping", "gain")



#: SEED/StationXML unit names as users read them.
_UNIT_WORDS = {"M/S": "m/s", "M/SEC": "m/s", "M/S**2": "m/s^2", "M/S/S": "m/s^2", "M": "m",
               "V": "V", "VOLTS": "V", "COUNTS": "counts", "COUNT": "counts"}


def units_label(output_units, input_units):
    """A response gain's units as users read them: ``"V/(m/s)"`` from
    StationXML's ``V`` and ``M/S``."""
    def word(u):
        u = str(u).strip()
        return _UNIT_WORDS.get(u.upper(), u)
    out, inp = word(output_units), word(input_units)
    return f"{out}/({inp})" if "/" in inp else f"{out}/{inp}"

def evaluate_velocity_response(response, freqs):
    """Complex velocity response (counts per m/s) of an ObsPy ``Response``:
    evaluated in numpy as evalresp does (:mod:`bayescal.core.response.evalresp`, no
    ``obspy.signal`` import), by ObsPy's evalresp for what that does not
    cover."""
    from ...errors import NotHandled
    from .evalresp import velocity_response

    freqs = np.asarray(freqs, dtype=float)
    try:
        return velocity_response(response, freqs)
    except NotHandled:
        pass
    h = response.get_evalresp_response_for_frequencies(
        freqs, output="VEL", hide_sensitivity_mismatch_warning=True)
    return np.asarray(h, dtype=complex)


def pendulum_coefficients(period_s, damping):
    """``(c1, c0) = (2 h w0, w0^2)``, ``w0 = 2 pi / T0``: the coefficients of
    the pendulum pair's factor :func:`pendulum_denominator`."""
    w0 = 2 * np.pi / period_s
    return 2.0 * damping * w0, w0 * w0


def pendulum_denominator(s, c1, c0):
    """The pendulum pair's factor ``D(s) = s^2 + c1 s + c0`` (module
    docstring; ``c1, c0`` from :func:`pendulum_coefficients`, or relative
    ones times the nominal). Every two-pole response of bayescal is written
    with it."""
    return s * s + c1 * s + c0


def pendulum_poles(period_s, damping):
    """(..., 2) pole pair in rad/s of periods and dampings (conjugate first
    with positive imaginary part; two real poles when overdamped)."""
    w0 = 2 * np.pi / np.asarray(period_s, float)
    h = np.asarray(damping, float)
    disc = np.sqrt((h ** 2 - 1).astype(complex))
    return np.stack([-w0 * (h - disc), -w0 * (h + disc)], axis=-1)


def _first_paz_stage(response):
    stages = getattr(response, "response_stages", None) or []
    if not stages or not hasattr(stages[0], "poles"):
        raise ResponseError("the first response stage is not poles and zeros")
    return stages[0]


@dataclass(frozen=True)
class TwoPoleFamily:
    """The parametric family of one channel (see module docstring).

    ``ratio`` is vectorised over walkers and is the only thing the likelihood
    calls; it never touches ObsPy.
    """

    period_s: float           # nominal T0
    damping: float            # nominal h
    gain: float               # nominal first-stage gain G_nom
    norm_freq: float          # first-stage normalisation frequency (Hz)
    gain_units: str

    @classmethod
    def from_response(cls, response):
        """Nominal T0, h, G read from the first (poles and zeros) stage."""
        st = _first_paz_stage(response)
        poles = np.array([complex(p) for p in st.poles])
        if poles.size < 2:
            raise ResponseError("the first stage has fewer than two poles")
        if "HERTZ" in str(st.pz_transfer_function_type).upper():
            poles = poles * 2.0 * np.pi
        p1, p2 = poles[np.argsort(np.abs(poles))[:2]]
        w0sq = (p1 * p2).real
        two_h_w0 = -(p1 + p2).real
        if w0sq <= 0:
            raise ResponseError("the two long-period poles do not form a pendulum pair")
        w0 = np.sqrt(w0sq)
        unit = getattr(st.input_units, "upper", lambda: str(st.input_units))()
        out = str(getattr(st, "output_units", "V"))
        fn = st.normalization_frequency or (response.instrument_sensitivity.frequency
                                            if response.instrument_sensitivity else 1.0)
        return cls(period_s=2 * np.pi / w0, damping=two_h_w0 / (2 * w0), gain=float(st.stage_gain),
                   norm_freq=float(fn), gain_units=units_label(out, unit))

    @staticmethod
    def denominator(s, w0, h):
        """The pendulum pair's factor ``D(s) = s^2 + 2 h w0 s + w0^2``
        (:func:`pendulum_denominator`)."""
        return pendulum_denominator(s, 2.0 * h * w0, w0 * w0)

    def inverse_ratio_at(self, freqs):
        """A fast vectorised ``(T0, h, G) -> H_nom(f) / H(f; T0, h, G)`` for
        fixed ``freqs`` (the likelihood's hot path: constants precomputed)."""
        s = 2j * np.pi * np.asarray(freqs, float)[None, :]
        sn = 2j * np.pi * self.norm_freq
        w0n = 2 * np.pi / self.period_s
        inv_d_nom = 1.0 / self.denominator(s, w0n, self.damping)
        scale = self.gain * abs(self.denominator(sn, w0n, self.damping))

        def inverse(period_s, damping, gain):
            c1, c0 = pendulum_coefficients(period_s[:, None], damping[:, None])
            d_new = pendulum_denominator(s, c1, c0)
            a_new = np.abs(pendulum_denominator(sn, c1, c0))
            return (scale / (gain[:, None] * a_new)) * d_new * inv_d_nom
        return inverse

    def ratio(self, freqs, period_s, damping, gain):
        """H(f; T0, h, G) / H_nom(f) for arrays of parameters.

        ``period_s``, ``damping``, ``gain`` have shape (W,) (or are scalars);
        returns shape (W, F).
        """
        s = 2j * np.pi * np.asarray(freqs)[None, :]
        sn = 2j * np.pi * self.norm_freq
        c1, c0 = pendulum_coefficients(np.atleast_1d(period_s)[:, None],
                                       np.atleast_1d(damping)[:, None])
        g = np.atleast_1d(gain)[:, None]
        c1n, c0n = pendulum_coefficients(self.period_s, self.damping)
        d_new = pendulum_denominator(s, c1, c0)
        d_nom = pendulum_denominator(s, c1n, c0n)
        a0 = np.abs(pendulum_denominator(sn, c1, c0)) / abs(pendulum_denominator(sn, c1n, c0n))
        return (g / self.gain) * a0 * d_nom / d_new

    def gain_only_ratio(self, gain):
        """H/H_nom when only the gain differs: (W,) -> (W, 1)."""
        return (np.atleast_1d(gain) / self.gain)[:, None]


@dataclass(frozen=True)
class ScaleFamily:
    """A channel's response known only up to a scale factor: the gain of a
    response whose first stage is not a pendulum pair (``flat`` metadata, a
    response of one gain stage). ``gain`` is the first stage's gain (or the
    overall sensitivity when the first stage carries none); fitting it
    multiplies the whole nominal response by ``gain / gain_nom`` (a relative
    gain), which needs no poles or zeros. Period and damping are undefined
    (NaN): only ``free="gain"`` uses this family. Such metadata are often a
    placeholder (``flat``: 1 count per m/s), so the gain's log-uniform prior
    spans ``gain_factor`` either side of it rather than the usual factor 10
    (:func:`gain_prior_factor`)."""

    gain: float
    norm_freq: float
    gain_units: str
    period_s: float = float("nan")
    damping: float = float("nan")
    gain_factor: float = 1e12

    @classmethod
    def from_response(cls, response):
        """The nominal scale of an ObsPy ``Response`` (see the class docstring)."""
        stages = getattr(response, "response_stages", None) or []
        sens = getattr(response, "instrument_sensitivity", None)
        if stages and stages[0].stage_gain:
            st = stages[0]
            unit = getattr(st.input_units, "upper", lambda: str(st.input_units))()
            return cls(gain=float(st.stage_gain),
                       norm_freq=float(st.stage_gain_frequency or getattr(sens, "frequency", 0)
                                       or 1.0),
                       gain_units=units_label(st.output_units, unit))
        if sens is not None and sens.value and len(stages) <= 1:
            # the sensitivity is the first stage's gain only when it is the only stage
            return cls(gain=float(sens.value), norm_freq=float(sens.frequency or 1.0),
                       gain_units=units_label(sens.output_units, sens.input_units))
        raise ResponseError("the response has neither a first-stage gain nor a sensitivity")

    gain_only_ratio = TwoPoleFamily.gain_only_ratio


def gain_prior_factor(family, priors):
    """How far (a factor either side) the gain's log-uniform prior reaches
    from the metadata gain: the family's own ``gain_factor`` when it has one
    (a :class:`ScaleFamily`), else ``priors.gain_factor``."""
    return getattr(family, "gain_factor", None) or priors.gain_factor


def response_family(response):
    """The parametric family of a channel's response: a
    :class:`TwoPoleFamily` when its first stage is a pendulum pair, else a
    :class:`ScaleFamily` (gain only), else None."""
    try:
        return TwoPoleFamily.from_response(response)
    except ResponseError:
        pass
    try:
        return ScaleFamily.from_response(response)
    except ResponseError:
        return None


def paz_velocity_response(freqs, period_s, damping, gain, extra_poles=(), digitizer_gain=1.0,
                          norm_freq=1.0):
    """Velocity response (counts per m/s) of an ideal broadband: two pendulum
    poles, two zeros at the origin, optional extra real poles (rad/s), gain
    ``gain`` (V per m/s) at ``norm_freq`` and a flat digitizer (counts/V).
    Used by the simulator to build the *true* responses independently of
    ObsPy's evaluation, and by tests as a second construction."""
    s = 2j * np.pi * np.asarray(freqs, dtype=float)
    sn = 2j * np.pi * norm_freq
    c1, c0 = pendulum_coefficients(period_s, damping)

    def paz(x):
        return x * x / pendulum_denominator(x, c1, c0) * transfer(x, (), extra_poles)

    return gain * digitizer_gain * paz(s) / np.abs(paz(sn))
