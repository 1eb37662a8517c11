"""A numpy evaluation of an ObsPy ``Response``, the same numbers as ObsPy's
``get_evalresp_response_for_frequencies`` without importing ``obspy.signal``.

Why: ObsPy's evaluation goes through ``obspy.signal.evrespwrapper``, whose
import pulls in ``obspy.signal`` and ``scipy.signal`` (about 2.4 s on the
2-core test machine), and evaluates stage by stage in C over every frequency
(0.3 s for one channel of a 2-hour 20-Hz record). ``bayescal fit``
deconvolves whole records, so both costs were most of a fit's start (issue
16).

What it reproduces is evalresp as ObsPy drives it (``check_channel``,
``norm_resp`` and ``calc_resp`` of ObsPy's bundled evalresp, read from its
source):

* stages in sequence order; an analog poles-and-zeros stage is
  ``A0 prod(s - z) / prod(s - p)`` with ``s = 2 pi i f`` (LAPLACE radians)
  or ``s = i f`` (LAPLACE hertz); a digital one is the same in
  ``z = exp(i w dt)``; coefficients with denominators are the ratio of the
  two polynomials in ``exp(-i w dt)``;
* an FIR given as plain coefficients (ObsPy hands it over as asymmetric)
  is rescaled to unit sum when its sum is more than 2 % off, and made
  symmetric when its coefficients are exactly mirrored; a symmetric FIR is
  evaluated with zero phase (its delay taken as corrected), an asymmetric
  one with its own phase and then advanced by the stage's applied
  correction (``exp(i w correction)``); a boxcar is evaluated as evalresp
  does (zero phase, then the correction);
* a stage whose gain frequency (or normalisation frequency) is not the
  sensitivity frequency is renormalised to its gain at the sensitivity
  frequency (``A0``/``h0`` recomputed there), and the overall gain is the
  product of the stage gains (not the reported sensitivity);
* the input units of the first stage convert to velocity (``M`` by
  ``1 / (i w)``, ``M/S**2`` by ``i w``; cm, mm, nm scaled to m).

Anything else (response lists, polynomial stages, repeated or unit-mismatched
stages, a missing decimation on a digital stage, unknown units) raises
:class:`NotHandled`, and :func:`bayescal.core.response.family.evaluate_velocity_response`
then asks ObsPy. ``tests/test_evalresp.py`` compares the two on every
response of ObsPy's own test data and of the shared real recordings.
"""
from __future__ import annotations

import numpy as np

from .paz import transfer
from ...errors import NotHandled

FIR_NORM_TOL = 0.02

_DIS, _VEL, _ACC = "DIS", "VEL", "ACC"
#: ObsPy's mapping of unit names to evalresp's unit kinds.
_KIND = {}
for _kind, _names in (
        (_DIS, "M NM CM MM M/M M**3/M**3"),
        (_VEL, "M/S M/SEC NM/S NM/SEC CM/S CM/SEC MM/S MM/SEC"),
        (_ACC, "M/S**2 M/(S**2) M/SEC**2 M/(SEC**2) M/S/S NM/S**2 NM/(S**2) NM/SEC**2 "
               "NM/(SEC**2) CM/S**2 CM/(S**2) CM/SEC**2 CM/(SEC**2) MM/S**2 MM/(S**2) "
               "MM/SEC**2 MM/(SEC**2)"),
        ("VOLTS", "V VOLT VOLTS V/M"), ("COUNTS", "COUNT COUNTS"), ("TESLA", "T"),
        ("PRESSURE", "PA PASCAL PASCALS MBAR")):
    _KIND.update(dict.fromkeys(_names.split(), _kind))
#: ObsPy's scale of the first stage's input units to metres (only these keys).
_SCALE = {**dict.fromkeys(("CM/S**2", "CM/S", "CM/SEC", "CM"), 1e2),
          **dict.fromkeys(("MM/S**2", "MM/S", "MM/SEC", "MM"), 1e3),
          **dict.fromkeys(("NM/S**2", "NM/S", "NM/SEC", "NM"), 1e9)}


def _unit(name):
    """(evalresp unit kind, scale to metres) of a unit name."""
    key = str(name).upper() if name else None
    if key not in _KIND:
        raise NotHandled(f"unit {name!r}")
    return _KIND[key], _SCALE.get(key, 1.0)


class _Stage:
    """One stage as evalresp sees it after ``check_channel``."""

    def __init__(self, st):
        kind = type(st).__name__
        self.seq = st.stage_sequence_number
        self.gain = st.stage_gain
        self.gain_freq = st.stage_gain_frequency
        self.has_gain = self.gain is not None and self.gain_freq is not None
        self.in_units, self.out_units = st.input_units, st.output_units
        self.dt = None
        deci = (st.decimation_correction, st.decimation_delay, st.decimation_factor,
                st.decimation_input_sample_rate, st.decimation_offset)
        if None not in deci:
            rate = st.decimation_input_sample_rate
            self.dt = 0.0 if rate == 0 else 1.0 / rate
            self.correction = float(st.decimation_correction)
        self.type, self.a0, self.a0_freq = None, 1.0, None
        read = {"PolesZerosResponseStage": self._read_paz,
                "CoefficientsTypeResponseStage": self._read_coefficients,
                "FIRResponseStage": self._read_fir, "ResponseStage": self._read_gain}.get(kind)
        if read is None:
            raise NotHandled(f"stage type {kind}")
        read(st)
        if self.type in ("FIR_ASYM", "FIR_SYM_1", "FIR_SYM_2") and not self.coeffs.size:
            self.type = "EMPTY"
        self.h0 = 1.0

    def _read_paz(self, st):
        tf = st.pz_transfer_function_type
        self.type = {"LAPLACE (RADIANS/SECOND)": "LAPLACE", "LAPLACE (HERTZ)": "ANALOG",
                     "DIGITAL (Z-TRANSFORM)": "IIR_PZ"}.get(tf)
        if self.type is None:
            raise NotHandled(f"transfer function {tf!r}")
        self.zeros = np.array([complex(z) for z in st.zeros])
        self.poles = np.array([complex(p) for p in st.poles])
        self.a0, self.a0_freq = st.normalization_factor, st.normalization_frequency
        if self.type == "IIR_PZ" and (self.zeros.size or self.poles.size) and self.dt is None:
            raise NotHandled("digital poles and zeros without decimation")
        if self.type == "IIR_PZ" and not (self.zeros.size or self.poles.size):
            self.type = "EMPTY"

    def _read_coefficients(self, st):
        num = np.array([float(c) for c in st.numerator])
        den = np.array([float(c) for c in st.denominator])
        if den.size:
            self.type, self.num, self.den = "IIR_COEFFS", num, den
        else:
            if str(st.cf_transfer_function_type).lower() != "digital":
                raise NotHandled("FIR that is not digital")
            self.type, self.coeffs = "FIR_ASYM", num
            self._check_sym()
        if self.dt is None:
            raise NotHandled("digital filter without decimation")

    def _read_fir(self, st):
        self.coeffs = np.array([float(c) for c in st.coefficients])
        self.type = {"NONE": "FIR_ASYM", "ODD": "FIR_SYM_1", "EVEN": "FIR_SYM_2"}.get(st.symmetry)
        if self.type is None:
            raise NotHandled(f"FIR symmetry {st.symmetry!r}")
        if self.type == "FIR_ASYM":
            self._check_sym()
        if self.dt is None:
            raise NotHandled("FIR without decimation")

    def _read_gain(self, st):
        if not self.has_gain:
            raise NotHandled("a stage with neither filter nor gain")
        if self.dt is not None:
            raise NotHandled("a decimation without a filter")
        self.type = "GAIN"

    def _check_sym(self):
        c = self.coeffs
        nc = c.size
        total = c.sum()
        if nc and (total < 1.0 - FIR_NORM_TOL or total > 1.0 + FIR_NORM_TOL):
            c = c / total
        if nc % 2 == 0:
            n0 = nc // 2
            if nc and np.array_equal(c[n0:], c[:n0][::-1]):
                self.type, c = "FIR_SYM_2", c[:n0]
        else:
            n0 = (nc - 1) // 2
            if np.array_equal(c[n0 + 1:], c[:n0][::-1]):
                self.type, c = "FIR_SYM_1", c[:nc - n0]
        self.coeffs = c

    def normalise(self, sensfreq):
        """``norm_resp`` for this stage: its gain moved to ``sensfreq`` (its
        ``A0`` or ``h0`` recomputed there); returns the gain."""
        if self.gain == 0.0:
            raise NotHandled("zero stage gain")
        pz = self.type in ("LAPLACE", "ANALOG", "IIR_PZ")
        if self.gain_freq != sensfreq or (pz and self.a0_freq != sensfreq):
            if self.type in ("LAPLACE", "ANALOG", "IIR_PZ", "FIR_SYM_1", "FIR_SYM_2", "FIR_ASYM",
                             "IIR_COEFFS"):
                if pz:
                    self.a0 = 1.0
                else:
                    self.h0 = 1.0
                df = abs(self._filt_norm(self.gain_freq))
                of = abs(self._filt_norm(sensfreq))
                if df == 0.0 or of == 0.0:
                    raise NotHandled("a gain frequency where the filter is zero")
                self.gain = self.gain / df * of
                self.gain_freq = sensfreq
                if pz:
                    self.a0, self.a0_freq = 1.0 / of, sensfreq
                else:
                    self.h0 = 1.0 / of
        return self.gain

    # -- evaluation of the filter (without the stage gain), vectorised -------
    def filt(self, freq):
        """The stage's filter at frequencies ``freq`` (Hz), as ``calc_resp``
        multiplies it in (the asymmetric FIR's correction included)."""
        freq = np.asarray(freq, float)
        w = 2 * np.pi * freq
        t = self.type
        if t in ("LAPLACE", "ANALOG"):
            return transfer(1j * (w if t == "LAPLACE" else freq), self.zeros, self.poles, self.a0)
        if t == "IIR_PZ":
            return transfer(np.exp(1j * w * self.dt), self.zeros, self.poles, self.a0)
        if t == "IIR_COEFFS":
            e = np.exp(-1j * np.outer(w * self.dt, np.arange(max(self.num.size, self.den.size))))
            return self.h0 * (e[:, :self.num.size] @ self.num) / (e[:, :self.den.size] @ self.den)
        if t == "FIR_SYM_1":
            a = self.coeffs
            na = a.size
            fact = na - 1 - np.arange(na - 1)
            r = np.cos(np.outer(w * self.dt, fact)) @ a[:-1]
            return (a[-1] + 2.0 * r) * self.h0 + 0j
        if t == "FIR_SYM_2":
            a = self.coeffs
            fact = a.size - 1 - np.arange(a.size) + 0.5
            return 2.0 * (np.cos(np.outer(w * self.dt, fact)) @ a) * self.h0 + 0j
        if t == "FIR_ASYM":
            return self._fir_asym(w) * np.exp(1j * w * self.correction)
        return np.ones_like(w, dtype=complex)      # GAIN, EMPTY

    def _fir_asym(self, w):
        a = self.coeffs
        ws = w * self.dt
        if np.all(a == a[0]):                       # evalresp's boxcar branch
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.sin(ws / 2.0 * a.size) / np.sin(ws / 2.0) * a[0]
            return np.where(ws == 0.0, 1.0, out) + 0j
        return self.h0 * (np.exp(-1j * np.outer(ws, np.arange(a.size))) @ a)

    def _filt_norm(self, freq):
        """The filter as ``norm_resp`` evaluates it (no correction shift)."""
        if self.type == "FIR_ASYM":
            return self._fir_asym(2 * np.pi * np.atleast_1d(float(freq)))[0]
        return self.filt(np.atleast_1d(float(freq)))[0]


def velocity_response(response, freqs):
    """Complex velocity response (counts per m/s) of an ObsPy ``Response`` at
    ``freqs`` (Hz), as ObsPy's evalresp gives it; raises :class:`NotHandled`
    for what this evaluation does not cover (see the module docstring)."""
    stages = _stages(response)
    sens = response.instrument_sensitivity
    first_in = stages[0].in_units or (sens.input_units if sens is not None else None)
    kind, scale = _unit(first_in)
    _check_units(stages)
    calc_sensit = _normalise(stages, _sensitivity_frequency(stages, sens))
    freqs = np.asarray(freqs, dtype=float)
    out = np.full(freqs.shape, calc_sensit * scale, dtype=complex)
    for st in stages:
        out *= st.filt(freqs)
    w = 2 * np.pi * freqs
    if kind == _DIS:
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(w != 0.0, out * (-1j / w), 0.0)
    elif kind == _ACC:
        out = out * (1j * w)
    return out


def _stages(response):
    """The response's stages in sequence order, as :class:`_Stage`."""
    raw = list(getattr(response, "response_stages", None) or [])
    if not raw:
        raise NotHandled("no response stages")
    seqs = [st.stage_sequence_number for st in raw]
    if len(set(seqs)) != len(seqs):
        raise NotHandled("a repeated stage number")
    return [_Stage(raw[i]) for i in np.argsort(seqs, kind="stable")]


def _check_units(stages):
    """``check_channel``'s units check: each filter stage's input units are
    of the kind of the previous filter stage's output units."""
    prev = None
    for st in stages:
        if st.type == "GAIN":
            continue
        if st.seq == 0 or st.in_units is None or st.out_units is None:
            raise NotHandled("a stage without units")
        if prev is not None and _unit(prev.out_units)[0] != _unit(st.in_units)[0]:
            raise NotHandled("units mismatch between stages")
        prev = st


def _sensitivity_frequency(stages, sens):
    """The frequency every stage gain is normalised to (``check_channel``):
    the sensitivity's, else the last stage gain's; a lone stage without gain
    takes the sensitivity as its gain."""
    if sens is not None:
        if not sens.value:
            raise NotHandled("a zero or missing sensitivity")
        sensit = float(sens.value)
        sensfreq = float(sens.frequency) if sens.frequency else 0.0
    else:
        sensit, sensfreq = 0.0, 0.0
    nstages = len(stages) + (sens is not None)
    if nstages == 1 and not stages[0].has_gain:
        raise NotHandled("one stage without gain")
    if nstages == 2 and not stages[0].has_gain and sens is not None:
        if sensit == 0.0:
            raise NotHandled("no stage gain and no sensitivity")
        stages[0].gain, stages[0].gain_freq, stages[0].has_gain = sensit, sensfreq, True
    if sens is None or sensit == 0.0:
        for st in stages:
            if st.has_gain and st.gain_freq != 0.0:
                sensfreq = float(st.gain_freq)
    return sensfreq


def _normalise(stages, sensfreq):
    """``norm_resp``: each stage's gain moved to ``sensfreq``
    (:meth:`_Stage.normalise`); returns the product of the stage gains."""
    calc_sensit = 1.0
    for st in stages:
        if st.has_gain:
            calc_sensit *= st.normalise(sensfreq)
    return calc_sensit
