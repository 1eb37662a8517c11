"""The coherence-ratio rule for tilt noise (:func:`tilt_signature`): the
coherence deficit on the horizontals against the verticals at long
periods. The test that names tilt noise is :mod:`bayescal.criticism.tilt`;
this rule is the baseline of validation/studies/tilt_power.py."""
from __future__ import annotations

import numpy as np

#: Horizontal/vertical coherence-deficit ratio (two lowest bands) naming tilt noise.
TILT_RATIO = 4.0


def tilt_signature(band_centres, coherence, horizontal):
    """Coherence deficit ``1 - coherence`` (B, n_u) on the horizontals
    against the verticals in the lowest third of the bands, and whether it
    grows toward long periods. Returns dict with ``score`` (ratio of
    deficits), ``rising`` and the channels concerned."""
    horizontal = np.asarray(horizontal, bool)
    deficit = np.clip(1.0 - coherence, 1e-6, 1)
    nb = deficit.shape[0]
    low, high = slice(0, min(2, nb)), slice(max(nb - 3, 0), None)
    if not horizontal.any():
        return {"score": 0.0, "rising": False, "channels": []}
    hz = np.flatnonzero(horizontal)
    h_low = deficit[low][:, hz].mean(axis=0)
    ref_level = (deficit[low][:, ~horizontal].mean() if (~horizontal).any()
                 else deficit[high][:, hz].mean())
    ratio = h_low / ref_level
    rising = h_low > TILT_RATIO * deficit[high][:, hz].mean(axis=0)
    chans = [int(i) for i, r, up, d in zip(hz, ratio, rising, h_low)
             if r > TILT_RATIO and up and d > 0.02]
    return {"score": float(ratio.max()), "rising": bool(rising.any()), "channels": chans,
            "deficit_low": h_low.tolist(), "reference_deficit": float(ref_level)}
