"""Readable names of a fit's sampled parameters, and a short text of a result.

The sampler's coordinates are named ``"<channel id>:<coordinate>"``
(``XX.SIM.10.BH1:orient_a``); :func:`parameter_label` says what each one is
in words a user reads (``"BH1 azimuth offset (tangent plane, rad)"``). The
internal names stay the result's keys (``Result.names``, ``result.json``'s
convergence entries).
"""
from __future__ import annotations

#: What each sampler coordinate is, for a channel whose nominal axis is
#: horizontal: the tangent plane at the nominal axis has its first
#: coordinate toward the east of it (an azimuth offset) and its second down
#: (a dip offset).
HORIZONTAL = {"orient_a": "azimuth offset (tangent plane, rad)",
              "orient_b": "dip offset (tangent plane, rad)"}
#: The same for a near-vertical nominal axis: tilts toward east and north.
VERTICAL = {"orient_a": "tilt toward east (tangent plane, rad)",
            "orient_b": "tilt toward north (tangent plane, rad)"}
#: Coordinates that mean the same on every channel.
COMMON = {"azimuth_rad": "azimuth (rad)", "log_gain": "log gain",
          "c0_rel": "(nominal period / period)^2",
          "c1_rel": "damping/period over its nominal value"}


def parameter_label(name, vertical=False):
    """A user-facing label of the sampler coordinate ``name``.

    Parameters
    ----------
    name : str
        ``"<channel id>:<coordinate>"`` as in :attr:`Result.names`.
    vertical : bool
        Whether the channel's nominal axis is (near) vertical, which sets
        what the two tangent-plane coordinates mean.

    Returns
    -------
    str
        ``"<channel code> <what it is>"``, e.g. ``"BHZ log gain"``; a name
        of no known coordinate is returned as it is.
    """
    cid, _, coord = name.rpartition(":")
    what = (VERTICAL if vertical else HORIZONTAL).get(coord) or COMMON.get(coord)
    if what is None:
        return name
    return f"{cid.split('.')[-1] or cid} {what}"


def _interval(entry, unit):
    ci = entry.get("ci95")
    return f"{entry['median']:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]{unit}"


def _estimated(entry):
    return (isinstance(entry, dict) and entry.get("median") is not None
            and None not in (entry.get("ci95") or [None]))


def channel_line(cid, summary):
    """One line of a channel's headline estimates (medians, 95 % intervals):
    the tilt from the vertical of a near-vertical channel, else azimuth and
    dip, and the gain relative to the metadata's (or the gain)."""
    angles = ("tilt_deg",) if _estimated(summary.get("tilt_deg")) else ("azimuth_deg", "dip_deg")
    parts = [f"{key.removesuffix('_deg')} {_interval(summary[key], ' deg')}" for key in angles
             if _estimated(summary.get(key))]
    response = summary.get("response") or {}
    for key in ("relative_gain", "gain"):
        if _estimated(response.get(key)):
            parts.append(f"{key.replace('_', ' ')} {_interval(response[key], '')}")
            break
    return f"  {cid}: " + ("; ".join(parts) or "no estimate")


def describe(result):
    """A short text of ``result``: its channels' headline estimates, the
    model check, the convergence and the sample count (``str(result)``)."""
    adequacy = result.adequacy or {}
    check = {True: "passed", False: "failed", None: "not run"}[adequacy.get("ok")]
    improved = ((result.meta.headline or {}).get("model") if result.meta else None) == "improved"
    lines = [f"bayescal Result: {len(result.channel_ids)} SUT channels, "
             f"{len(result.samples)} samples of {len(result.names)} parameters"
             + (", estimates under the criticism's improved model" if improved else ""),
             "medians [95 % intervals]:"]
    lines += [channel_line(cid, result.channels.get(cid, {})) for cid in result.channel_ids]
    lines += [f"  {cid}: not estimable ({why})" for cid, why in
              (result.not_estimable or {}).items() if cid not in result.channel_ids]
    lines.append(f"model check: {check}; converged: {result.convergence.converged}")
    lines.append("(.summary() is result.json's content; .names the sampled parameters, "
                 ".labels what each one is)")
    return "\n".join(lines)
