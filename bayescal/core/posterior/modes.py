"""The modes a fit found, read from its ``multimodal`` report: which hold
enough probability, which intervals of a channel's summary they lie outside,
and the line that tells a user (the search itself:
:mod:`bayescal.core.fit.modes`)."""
from __future__ import annotations


def significant_modes(report):
    """The modes of a ``multimodal`` entry that hold at least its threshold."""
    if not report or not report.get("detected"):
        return []
    return [m for m in report["modes"] if m["mass_fraction"] >= report["mass_threshold"]]


def mark(entry, values, azimuth=False):
    """Mark an interval summary ``entry`` (with ``ci95``) as multimodal when a
    significant mode's value (``values``: list of (value, mass fraction),
    the sampled mode first) lies outside it: adds ``multimodal``, ``modes`` and a note. Returns
    whether it marked."""
    if "ci95" not in entry or len(values) < 2:
        return False
    lo, hi = entry["ci95"]
    med = entry["median"]
    shown = []
    outside = False
    for v, f in values:
        if azimuth:
            v = med + (v - med + 180.0) % 360.0 - 180.0
        shown.append({"value": float(v), "mass_fraction": float(f)})
        outside |= not (lo <= v <= hi)
    if not outside:
        return False
    main = shown[0]["mass_fraction"]
    entry.update({"multimodal": True, "modes": shown,
                  "note": f"multimodal: this interval covers the sampled mode only (mass "
                          f"{100 * main:.0f} %); see modes"})
    return True


def mark_channel(entry, cid, report):
    """Mark the intervals of one channel's ``channel_summary`` entry that a
    significant mode of ``report`` (the ``multimodal`` entry) lies outside.
    Returns the names of the marked quantities."""
    modes = significant_modes(report)
    if len(modes) < 2:
        return []
    marked = []
    values = [(m["channels"].get(cid, {}), m["mass_fraction"]) for m in modes]
    for name in ("azimuth_deg", "dip_deg"):
        e = entry.get(name, {})
        if not e.get("undefined") and name in values[0][0] and \
                mark(e, [(v[name], f) for v, f in values], azimuth=name == "azimuth_deg"):
            marked.append(name)
    response = entry.get("response", {})
    for name in ("period_s", "damping", "gain"):
        if name in response and name in values[0][0] and \
                mark(response[name], [(v[name], f) for v, f in values]):
            marked.append(name)
    nominal = (entry.get("nominal") or {}).get("gain")
    if "relative_gain" in response and nominal and "gain" in values[0][0] and \
            mark(response["relative_gain"], [(v["gain"] / nominal, f) for v, f in values]):
        marked.append("relative_gain")
    return marked


def describe(report, marked=None):
    """One line for a user when the posterior is multimodal (else None): the
    modes' masses and, when given, the intervals marked (``{channel:
    [quantities]}``)."""
    modes = significant_modes(report)
    if len(modes) < 2:
        return None
    masses = ", ".join(f"{100 * m['mass_fraction']:.0f} %" for m in modes)
    where = "; ".join(f"{cid}: {', '.join(q)}" for cid, q in (marked or {}).items() if q)
    return (f"MULTIMODAL POSTERIOR: {len(modes)} modes hold {masses} of the probability: the "
            "data fit more than one set of values, and the intervals printed are those of the "
            "most probable set only"
            + (f"; another set lies outside them for {where}" if where else "")
            + "; every set's values are under \"multimodal\" in result.json (how modes are "
            "found: docs/validation/multimodal.md)")


def multimodal_line(summary):
    """:func:`describe` from a ``result.json`` summary (the marked intervals
    read off its channels), or None."""
    marked = {cid: [k for k, v in [*e.items(), *e.get("response", {}).items()]
                    if isinstance(v, dict) and v.get("multimodal")]
              for cid, e in summary.get("channels", {}).items()}
    return describe(summary.get("multimodal"), marked)
