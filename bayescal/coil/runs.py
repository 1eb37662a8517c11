"""One coil calibration run: the driven element, its recorded outputs and the
coil input, aligned, and their cross-spectra (input deconvolved to ground
velocity through the coil constant).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, ResponseError
from ..core.response import TwoPoleFamily, evaluate_velocity_response
from .triaxial import ELEMENTS, XYZ, output_axis


#: Narrow bands: the response ratio barely changes within one.
BANDS_PER_DECADE = 20
#: Segments hold at most this many periods of the band's lower edge (power
#: of two). With a recorded input they need not hold more than one: outputs
#: are deconvolved over the whole record before segmenting (and, in the
#: second pass, by the fitted response), so what a segment's window smooths
#: is the nearly flat ratio of true to assumed response, not the response.
SEGMENT_CYCLES = 10
#: Segments are shortened (by halving) until the record gives at least this
#: many half-overlapping ones: the noise model's power is measured over them.
MIN_SEGMENTS = 12
#: Periods of the band's lower edge cut at each end of a gap-free run (the
#: deconvolution's transient).
EDGE_PERIODS = 2.0


def calibration_nperseg(fs, fmin, n_samples):
    """Segment length (samples, a power of two) for a calibration run of
    ``n_samples``: ``SEGMENT_CYCLES`` periods of ``fmin``, halved while the
    record (less its edges) gives fewer than ``MIN_SEGMENTS`` half-overlapping
    segments, but never below 64 samples."""
    usable = max(n_samples - 2 * int(EDGE_PERIODS * fs / fmin), 0)
    want = int(2 ** np.ceil(np.log2(SEGMENT_CYCLES * fs / fmin)))
    while want > 64 and 2 * usable / want - 1 < MIN_SEGMENTS:
        want //= 2
    return want


def default_band(fs, duration_s, period_s, fmax_cycles=25.0):
    """Default analysis band of a calibration run: from half the natural
    frequency (raised to where a segment of the record still holds a period)
    to ``fmax_cycles`` times it, below ``fs / 4``."""
    fmin = 0.5 / period_s
    seg = calibration_nperseg(fs, fmin, int(duration_s * fs)) / fs
    fmin = max(fmin, 1.0 / seg)
    return fmin, max(min(fmax_cycles / period_s, fs / 4), 4 * fmin)

# --- reading one calibration run --------------------------------------------


@dataclass
class CalRun:
    """One run: element ``element`` driven, its outputs and input aligned."""

    element: str
    source: str
    axes: list            # per output: X, Y, Z, U, V or W
    ids: list
    data: np.ndarray      # (n_out, N) counts, NaN in gaps
    input: np.ndarray     # (N,) counts
    fs: float
    responses: list       # ObsPy Response per output
    families: list        # TwoPoleFamily per output
    cache: dict = field(default_factory=dict, repr=False)   # nominal responses by (id, grid)

    def nominal_response(self, freqs):
        """(n_out, F) nominal velocity responses (counts per m/s), cached."""
        key = (freqs.size, float(freqs[0]), float(freqs[-1]))
        for cid, r in zip(self.ids, self.responses):
            if (cid, key) not in self.cache:
                self.cache[(cid, key)] = evaluate_velocity_response(r, freqs)
        return np.array([self.cache[(cid, key)] for cid in self.ids])

    def select(self, axes):
        """The same run restricted to the outputs on ``axes``."""
        keep = [i for i, a in enumerate(self.axes) if a in axes]
        return CalRun(self.element, self.source, [self.axes[i] for i in keep],
                      [self.ids[i] for i in keep], self.data[keep], self.input, self.fs,
                      [self.responses[i] for i in keep], [self.families[i] for i in keep],
                      self.cache)

    def coefficients(self, m):
        """``m_c`` per output: ``M[n, c]`` for XYZ outputs, ``delta_nc`` for UVW."""
        n = ELEMENTS.index(self.element)
        return np.array([m[n, XYZ.index(a)] if a in XYZ else float(a == self.element)
                         for a in self.axes])


def _as_float(tr):
    d = tr.data
    if np.ma.isMaskedArray(d):
        return np.ma.filled(d.astype(float), np.nan)
    return d.astype(float)


def read_run(element, stream, inventory, input_channel, source):
    """A :class:`CalRun` from one file's Stream and the SUT Inventory.

    The input channel is matched on its channel code (``BC0``) or full SEED
    id; outputs are all other channels whose code ends in N/E/Z/1/2 (XYZ) or
    U/V/W. Raises :class:`InputError` naming ``source``.
    """
    if element not in ELEMENTS:
        raise InputError(f"{source}: element must be U, V or W, not {element!r}")
    st = stream.copy()
    st.merge(method=0, fill_value=None)
    inp = [tr for tr in st if input_channel in (tr.stats.channel, tr.id)]
    if len(inp) != 1:
        raise InputError(f"{source}: {'no' if not inp else 'more than one'} input channel "
                         f"{input_channel} (channels: {', '.join(tr.id for tr in st) or 'none'})")
    outs = [tr for tr in st if tr is not inp[0] and output_axis(tr.stats.channel)]
    if not outs:
        raise InputError(f"{source}: no sensor output channel (codes ending in N/E/Z/1/2 "
                         "or U/V/W)")
    axes = [output_axis(tr.stats.channel) for tr in outs]
    if len(set(axes)) != len(axes):
        raise InputError(f"{source}: two output channels on one axis ({', '.join(tr.id for tr in outs)})")
    if set(axes) & set(XYZ) and set(axes) & set(ELEMENTS):
        raise InputError(f"{source}: both XYZ and UVW outputs in one run")
    trs = [inp[0]] + outs
    rates = {tr.stats.sampling_rate for tr in trs}
    if len(rates) != 1:
        raise InputError(f"{source}: sampling rates differ between channels: {sorted(rates)} Hz")
    fs = rates.pop()
    arrays = _on_one_grid(trs, fs, source)
    responses, families = _nominal_responses(outs, inventory, source)
    order = np.argsort([("XYZUVW").index(a) for a in axes])
    return CalRun(element=element, source=source, axes=[axes[i] for i in order],
                  ids=[outs[i].id for i in order], data=np.array(arrays[1:])[order],
                  input=arrays[0], fs=float(fs), responses=[responses[i] for i in order],
                  families=[families[i] for i in order])


def _on_one_grid(traces, fs, source):
    """The traces' samples on the time grid they share (NaN where a trace
    has none), one array each."""
    t0 = max(tr.stats.starttime for tr in traces)
    t1 = min(tr.stats.endtime for tr in traces)
    if t1 <= t0:
        raise InputError(f"{source}: input and outputs do not overlap in time")
    n = int(np.floor((t1 - t0) * fs)) + 1
    arrays = []
    for tr in traces:
        off = int(round((tr.stats.starttime - t0) * fs))
        x = np.full(n, np.nan)
        src = _as_float(tr)
        lo, hi = max(off, 0), min(off + src.size, n)
        x[lo:hi] = src[lo - off:hi - off]
        arrays.append(x)
    return arrays


def _nominal_responses(outs, inventory, source):
    """Each output's nominal ObsPy Response and its two-pole family, from
    the SUT Inventory."""
    responses, families = [], []
    for tr in outs:
        sel = inventory.select(network=tr.stats.network, station=tr.stats.station,
                               location=tr.stats.location, channel=tr.stats.channel,
                               time=tr.stats.starttime)
        try:
            resp = sel[0][0][0].response
        except IndexError:
            raise InputError(f"{source}: channel {tr.id} is not in the SUT StationXML") from None
        if resp is None or not resp.response_stages:
            raise InputError(f"{source}: channel {tr.id} has no response in the SUT StationXML")
        try:
            families.append(TwoPoleFamily.from_response(resp))
        except ResponseError as exc:
            raise InputError(f"{source}: channel {tr.id}: {exc}") from None
        responses.append(resp)
    return responses, families
