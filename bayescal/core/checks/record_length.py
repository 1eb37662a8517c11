"""Is the record long enough for the band's lower edge?

The noise model of a fit is measured from the record's own segments, band by
band. Where the record holds few periods of the band's lower edge, the
lowest bands rest on few segments of few cycles each. The sampling error of
that noise model is allowed for (:mod:`bayescal.core.model.plugin`, a weight per
band); on simulations (docs/validation/errors_in_variables.md, "Short records"; 40 pairs
each at 10 Hz, coherence 0.9, reference noise-free, gains free,
``--ref-noise quiet``; ``python benchmarks/short_records.py``, stored in
``reports/eiv/short_records_weighted.json``) the standardised errors'
standard deviations are:

=========================================  ==================================
record, band 0.02-1 Hz unless said         azimuth, dip, gain: z sd
(used: periods of the lower edge)          (1 for intervals of the right width)
=========================================  ==================================
900 s (614 s used: 12 periods)             1.13, 1.08, 1.01
1800 s (1536 s: 31 periods)                0.96, 1.15, 1.04
3600 s (3379 s: 68 periods)                0.86, 0.96, 0.99
900 s, band 0.05-1 Hz (768 s: 38 periods)  1.02, 1.04, 0.98
=========================================  ==================================

Every kind is inside its 99 % binomial band in these rows, but the short
records' angles scatter 8-13 % more than their intervals say (the
approximation behind the weights is a many-band one, and the lowest band's
segments overlap), so a fit says when its record holds fewer than
:data:`MIN_PERIODS` periods of the band's lower edge. The threshold is
loosely placed: the 31- and 38-period cases differ in band as well as in
length.
"""
from __future__ import annotations

#: Fewer periods of the band's lower edge than this in the record used: a note
#: (between the 31, whose dips' z sd was high, and the 38 measured inside;
#: a rough line, not a measured edge).
MIN_PERIODS = 35.0


def record_length_entry(seconds, lower_edge_hz):
    """``meta["record_length"]``: the record used (s), the band's lower edge
    (Hz), the periods of it the record holds, and, when fewer than
    :data:`MIN_PERIODS`, a ``note`` in plain words."""
    periods = float(seconds) * float(lower_edge_hz)
    out = {"seconds": float(seconds), "lower_edge_hz": float(lower_edge_hz),
           "periods_of_lower_edge": periods, "min_periods": MIN_PERIODS}
    if periods < MIN_PERIODS:
        out["note"] = (f"short record for the band: {seconds:.0f} s hold {periods:.1f} periods of "
                       f"its lower edge {lower_edge_hz:.3g} Hz (fewer than {MIN_PERIODS:.0f}); the "
                       "noise level is then measured from few segments and the intervals may be "
                       "somewhat too narrow (angles by about 10 % on simulated records of 12 such "
                       "periods: docs/validation/errors_in_variables.md); a longer record or a higher lower "
                       "edge (--band) avoids it")
    return out
