"""Reversed or exchanged channels, from the fitted axes against the metadata
axes: the screen that proposes them (the BIC of the metadata's axes against
the axes with a finding decides, :func:`.search.orientation_score`).

A channel whose fitted axis is within :data:`MATCH_DEG` of minus its
metadata axis is reversed; two channels whose fitted axes lie on each
other's metadata axes are exchanged; and a fitted channel far from its own
axis and on the metadata axis of a channel the fit could not use (no
coherence with the reference) is exchanged with that one.
"""
from __future__ import annotations

import numpy as np

#: Angle (degrees) within which a fitted axis "matches" a metadata axis.
MATCH_DEG = 30.0


def _angle(a, b):
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1, 1))))


def swaps_with_unfitted(fitted, nominal, ids, unfitted, taken=()):
    """Exchanged channels of which one could not be fitted (no coherence
    with the reference: the motion it records, the other's metadata axis,
    is one the wavefield hardly has): a fitted channel whose axis lies more
    than 60 degrees from its metadata axis and within :data:`MATCH_DEG` of
    an unfitted channel's. ``unfitted`` {channel id: metadata axis (3,)};
    ``taken``: channels already in a finding. Returns findings whose
    ``axis`` is the fitted channel's axis under the exchange."""
    out = []
    for i, cid in enumerate(ids):
        if cid in taken or _angle(fitted[i], nominal[i]) <= 60:
            continue
        for other, axis in unfitted.items():
            if other in taken or _angle(fitted[i], axis) >= MATCH_DEG:
                continue
            out.append({"name": "channel_swap", "rows": [i], "channels": sorted([cid, other]),
                        "axis": np.asarray(axis, float),
                        "explanation": f"{cid} and {other} are exchanged: {cid}'s fitted axis "
                                       f"is {other}'s metadata axis ({other} itself could not "
                                       "be fitted: the reference hardly sees the motion along "
                                       f"{cid}'s metadata axis; wiring or channel naming "
                                       "swapped)"})
            break
    return out


def orientation_findings(fitted, nominal, ids):
    """Compare fitted axes (n, 3) with metadata axes (n, 3): a channel whose
    fitted axis is within :data:`MATCH_DEG` of minus its metadata axis is a
    polarity reversal; two channels whose fitted axes match each other's
    metadata axes are swapped. Returns a list of findings (dicts)."""
    out = []
    n = len(ids)
    swapped = set()
    for i in range(n):
        for j in range(i + 1, n):
            if (_angle(fitted[i], nominal[j]) < MATCH_DEG and _angle(fitted[j], nominal[i]) < MATCH_DEG
                    and _angle(fitted[i], nominal[i]) > 60):
                swapped |= {i, j}
                out.append({"name": "channel_swap", "rows": [i, j], "channels": [ids[i], ids[j]],
                            "explanation": f"{ids[i]} and {ids[j]} are exchanged: each one's "
                                           "fitted axis is the other's metadata axis (wiring "
                                           "or channel naming swapped)"})
    for i in range(n):
        if i in swapped:
            continue
        if _angle(fitted[i], -nominal[i]) < MATCH_DEG:
            out.append({"name": "polarity_reversal", "rows": [i], "channels": [ids[i]],
                        "explanation": f"{ids[i]} is wired backwards: its fitted axis points "
                                       f"{_angle(fitted[i], nominal[i]):.0f} degrees from its "
                                       "metadata axis (polarity reversed)"})
    return out
