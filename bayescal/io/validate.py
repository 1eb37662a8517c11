"""Checks of the metadata values a fit uses, made when the metadata are read.

ObsPy reads a StationXML number it cannot parse in several ways: as None
(a sensitivity, a stage gain, an azimuth), as 0 (the real or imaginary part
of a pole or zero) or not at all (a decimation, which then fails deep inside
the response evaluation). So the checks work on two levels:

* :func:`scan_stationxml` reads the file's text and notes, per channel
  epoch, the first number (azimuth, dip, sample rate, or any number of the
  response) that is not a finite number as written;
* :func:`channel_problem` checks the values of an ObsPy ``Channel`` as read
  (any metadata format, or an Inventory given to the API): azimuth and dip
  finite and in range, sample rate positive, sensitivity and stage gains
  finite and non-zero, poles and zeros finite (an analog pole in the left
  half plane), normalisation factors finite and non-zero, decimations
  complete, coefficients finite, the gain the fit scales positive; then
  that the response evaluates to a finite velocity response of a size a
  recording can have.

Each problem is one sentence; :func:`bayescal.io.read.channel_meta` raises
it as an :class:`bayescal.errors.InputError` naming the file and the
channel, so the command line ends with one line and exit code 2.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["scan_stationxml", "channel_problem", "epoch_key"]

#: Numbers of a channel (its direct children) that a fit uses.
CHANNEL_NUMBERS = {"Azimuth", "Dip", "SampleRate"}
#: Numbers inside a channel's Response (any depth).
RESPONSE_NUMBERS = {"Value", "Frequency", "Real", "Imaginary", "NormalizationFactor",
                    "NormalizationFrequency", "InputSampleRate", "Factor", "Offset", "Delay",
                    "Correction", "Numerator", "Denominator", "NumeratorCoefficient",
                    "Coefficient", "Amplitude", "Phase", "FrequencyLowerBound",
                    "FrequencyUpperBound", "ApproximationLowerBound", "ApproximationUpperBound",
                    "MaximumError"}
#: The velocity response at the sensitivity frequency, counts per m/s, must
#: lie within these bounds (recordings of any sensor do, by many decades).
RESPONSE_SIZE = (1e-30, 1e30)


def _local(tag):
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def epoch_key(seed_id, start):
    """The key of one channel epoch: SEED id and start time as ObsPy prints it."""
    from obspy import UTCDateTime

    try:
        start = str(UTCDateTime(start)) if start is not None else None
    except Exception:
        start = str(start)
    return seed_id, start


#: Words of a number's place in StationXML, as a message says them.
WORDS = {"Response": "", "PolesZeros": "", "Coefficients": "", "FIR": "", "Polynomial": "",
         "ResponseList": "", "InstrumentSensitivity": "sensitivity", "StageGain": "gain",
         "Value": "value", "Frequency": "frequency", "Real": "real part",
         "Imaginary": "imaginary part", "SampleRate": "sample rate", "Azimuth": "azimuth",
         "Dip": "dip", "NormalizationFactor": "normalization factor",
         "NormalizationFrequency": "normalization frequency", "Decimation": "decimation",
         "InputSampleRate": "input sample rate", "Factor": "factor", "Offset": "offset",
         "Delay": "delay", "Correction": "correction"}


def _words(labels):
    parts = []
    for label in labels:
        head, _, number = label.partition(" ")
        word = WORDS.get(head, head.lower() if head not in ("stage",) else head)
        if word:
            parts.append(f"{word} {number}".strip() if number else word)
    return " ".join(parts) or "a number"


def _number_problem(text):
    """None if ``text`` is a finite number, else how it is not."""
    t = (text or "").strip()
    if not t:
        return "is empty, not a number"
    try:
        x = float(t)
    except ValueError:
        return f"{t[:40]!r} is not a number"
    if not math.isfinite(x):
        return f"{t[:40]!r} is not a finite number"
    return None


def scan_stationxml(path):
    """{(SEED id, start): problem} for the channel epochs of the StationXML
    file ``path`` holding a number the fit uses that is not a finite number
    as written (only the first such number of each epoch). Files that are
    not XML give {} (ObsPy's reader judges them)."""
    from lxml import etree

    out = {}
    stack, codes, labels = [], {}, []
    try:
        for event, elem in etree.iterparse(str(path), events=("start", "end"),
                                           huge_tree=True, recover=False):
            name = _local(elem.tag)
            if event == "start":
                stack.append(name)
                if name in ("Network", "Station"):
                    codes[name] = elem.get("code", "")
                elif name == "Channel":
                    codes["Channel"] = (elem.get("code", ""), elem.get("locationCode", ""),
                                        elem.get("startDate"))
                label = name
                if elem.get("number") is not None and name != "Stage":
                    label = f"{name} {elem.get('number')}"
                elif name == "Stage":
                    label = f"stage {elem.get('number', '?')}"
                labels.append(label)
                continue
            stack.pop()
            label = labels.pop()
            if "Channel" in stack or name == "Channel":
                in_response = "Response" in stack
                direct = stack and stack[-1] == "Channel" and name in CHANNEL_NUMBERS
                if direct or (in_response and name in RESPONSE_NUMBERS):
                    problem = _number_problem(elem.text)
                    if problem:
                        cha, loc, start = codes.get("Channel", ("", "", None))
                        sid = f"{codes.get('Network', '')}.{codes.get('Station', '')}.{loc}.{cha}"
                        i = stack.index("Channel") + 1
                        where = _words(labels[i:] + [label])
                        out.setdefault(epoch_key(sid, start), f"{where} {problem}")
            if name == "Channel":
                elem.clear()
    except etree.XMLSyntaxError:
        return out
    except OSError:
        return out
    return out


def _finite(x):
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _stage_problem(k, st):
    """The first problem of response stage ``st`` (number ``k``), or None."""
    name = f"response stage {k}"
    gain = getattr(st, "stage_gain", None)
    if gain is None and type(st).__name__ != "PolynomialResponseStage":
        return f"{name} has no gain (missing or not a number)"
    if gain is not None and not (_finite(gain) and float(gain) != 0):
        return f"{name} gain {gain!r} is not a finite, non-zero number"
    freq = getattr(st, "stage_gain_frequency", None)
    if freq is not None and not (_finite(freq) and float(freq) >= 0):
        return f"{name} gain frequency {freq!r} is not a finite, non-negative number"
    for what in ("poles", "zeros"):
        values = getattr(st, what, None)
        if values is None:
            continue
        for v in values:
            try:
                c = complex(v)
            except (TypeError, ValueError):
                return f"{name}: a {what[:-1]} ({v!r}) is not a number"
            if not (math.isfinite(c.real) and math.isfinite(c.imag)):
                return f"{name}: {what[:-1]} {c} is not finite"
            analog = "LAPLACE" in str(getattr(st, "pz_transfer_function_type", "")).upper()
            if what == "poles" and analog and c.real > 0:
                return (f"{name}: pole {c} lies in the right half plane (an unstable "
                        "response; a sign lost?)")
    if hasattr(st, "normalization_factor"):
        a0 = st.normalization_factor
        if not (_finite(a0) and float(a0) != 0):
            return f"{name} normalization factor {a0!r} is not a finite, non-zero number"
        f0 = st.normalization_frequency
        if f0 is not None and not (_finite(f0) and float(f0) >= 0):
            return f"{name} normalization frequency {f0!r} is not a finite, non-negative number"
    for what in ("numerator", "denominator", "coefficients"):
        values = getattr(st, what, None)
        if values is None:
            continue
        try:
            ok = np.all(np.isfinite(np.asarray([float(v) for v in values], float)))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            word = "coefficient" if what == "coefficients" else what[:-1]
            return f"{name}: a {word} is not a number"
    dec = [getattr(st, a, None) for a in ("decimation_input_sample_rate", "decimation_factor",
                                          "decimation_offset", "decimation_delay",
                                          "decimation_correction")]
    if any(d is not None for d in dec):
        rate, factor, offset, delay, corr = dec
        if not (_finite(rate) and float(rate) > 0):
            return f"{name} decimation input sample rate {rate!r} is not a positive number"
        if not (_finite(factor) and float(factor) >= 1 and float(factor) == int(float(factor))):
            return f"{name} decimation factor {factor!r} is not a positive integer"
        if not (_finite(offset) and float(offset) >= 0):
            return f"{name} decimation offset {offset!r} is not a non-negative integer"
        if not (_finite(delay) and _finite(corr)):
            return f"{name} decimation delay/correction ({delay!r}, {corr!r}) is not a number"
    return None


def channel_problem(ch, sampling_rate=None):
    """The first problem (one sentence) of the values of ObsPy channel
    ``ch`` a fit uses, or None. ``sampling_rate``: of the recording (the
    response is evaluated below its Nyquist frequency)."""
    az, dip = ch.azimuth, ch.dip
    if az is not None and not (_finite(az) and -360.0 <= float(az) <= 360.0):
        return f"azimuth {az!r} is not a number of degrees in [0, 360]"
    if dip is not None and not (_finite(dip) and -90.0 <= float(dip) <= 90.0):
        return f"dip {dip!r} is not a number of degrees in [-90, 90]"
    sr = ch.sample_rate
    if sr is not None and not (_finite(sr) and float(sr) > 0):
        return f"sample rate {sr!r} is not a positive number"
    resp = ch.response
    if resp is None or not resp.response_stages:
        return None            # said by the caller, with its own wording
    sens = resp.instrument_sensitivity
    if sens is not None:
        if not (_finite(sens.value) and float(sens.value) != 0):
            return f"sensitivity value {sens.value!r} is not a finite, non-zero number"
        if not (_finite(sens.frequency) and float(sens.frequency) >= 0):
            return f"sensitivity frequency {sens.frequency!r} is not a finite, non-negative number"
    for k, st in enumerate(resp.response_stages, 1):
        problem = (_stage_problem(getattr(st, "stage_sequence_number", None) or k, st)
                   or _bandpass_problem(getattr(st, "stage_sequence_number", None) or k, st,
                                        sens))
        if problem:
            return problem
    return (_gain_problem(resp)
            or _evaluation_problem(resp, sampling_rate or (float(sr) if sr else None)))


def _bandpass_problem(k, st, sens):
    """An analog stage with a zero at 0 Hz has no gain at 0 Hz: its gain,
    normalisation and the sensitivity must be given at a positive frequency
    (evalresp refuses the response otherwise)."""
    analog = "LAPLACE" in str(getattr(st, "pz_transfer_function_type", "")).upper()
    if not analog or not any(complex(z) == 0 for z in (getattr(st, "zeros", None) or [])):
        return None
    for what, f in ((f"response stage {k} gain frequency", st.stage_gain_frequency),
                    (f"response stage {k} normalization frequency", st.normalization_frequency),
                    ("sensitivity frequency", getattr(sens, "frequency", None))):
        if f is not None and float(f) == 0:
            return (f"{what} is 0 Hz, where the response (a zero at 0 Hz) is zero: a gain "
                    "needs a positive frequency")
    return None


def _gain_problem(resp):
    """The gain the fit scales (the first stage's, or the sensitivity) must
    be positive: the fit works with its logarithm."""
    from ..core.response import response_family

    try:
        family = response_family(resp)
    except Exception:           # judged by the evaluation below
        return None
    gain = getattr(family, "gain", None)
    if gain is not None and not float(gain) > 0:
        return (f"the sensor's gain {float(gain):g} (first stage, or the sensitivity) is not "
                "positive: the fit takes gains as positive numbers (a reversed polarity is "
                "an axis turned over: azimuth + 180, dip negated)")
    return None


def _evaluation_problem(resp, fs):
    """None when the response evaluates to finite velocity responses below
    Nyquist and a plausible size at its sensitivity frequency."""
    from ..core.response import evaluate_velocity_response

    sens = resp.instrument_sensitivity
    f_ref = float(sens.frequency) if sens is not None and sens.frequency else 1.0
    nyquist = fs / 2 if fs else None
    freqs = [f for f in (1e-3, 1e-2, 0.1, 1.0, f_ref) if nyquist is None or f < nyquist]
    freqs = np.array(sorted(set(freqs)) or [f_ref])
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            h = np.asarray(evaluate_velocity_response(resp, freqs), complex)
    except Exception as exc:   # ObsPy's evalresp raises many kinds
        text = str(exc).strip().splitlines()
        return ("the response cannot be evaluated"
                + (f" (ObsPy's evalresp: {text[0][:120]})" if text else ""))
    if not np.all(np.isfinite(h)):
        return "the response evaluates to a non-finite value"
    size = abs(h[int(np.argmin(np.abs(freqs - f_ref)))])
    if not RESPONSE_SIZE[0] <= size <= RESPONSE_SIZE[1]:
        return (f"the response's size at {freqs[int(np.argmin(np.abs(freqs - f_ref)))]:g} Hz "
                f"is {size:.3g} counts per m/s, outside any recording's "
                f"[{RESPONSE_SIZE[0]:g}, {RESPONSE_SIZE[1]:g}]")
    return None
