"""How far modelling the named effects moves a fit's estimates: each
estimate's shift in the fit's own standard deviations, and the sentence
that says it, largest first."""
from __future__ import annotations

import numpy as np

#: An estimate "moves" when the improved model shifts it by more than this
#: many of its standard deviations (the fit's 68 % half-width).
MOVE_SD = 0.3


def half_width(entry):
    """The 68 % half-width of a summary entry (nan without an interval)."""
    lo, hi = entry.get("ci68", (np.nan, np.nan))
    return 0.5 * (hi - lo)


def improved_estimates(base_summary, final_summary):
    """Per channel, each estimate under the improved model (median and 95 %
    interval) and ``moved_sd``: its shift from the fit's median (azimuths the
    short way round) in the fit's own standard deviations (68 % half-width)."""
    out = {}
    for cid, b in base_summary["channels"].items():
        f = final_summary["channels"].get(cid)
        if f is None:
            continue
        entry = {}
        pairs = [(k, b.get(k, {}), f.get(k, {})) for k in ("azimuth_deg", "dip_deg")]
        pairs += [(k, v, f.get("response", {}).get(k, {}))
                  for k, v in b.get("response", {}).items()]
        for key, be, fe in pairs:
            if "ci68" not in be or "ci68" not in fe or be.get("undefined") or fe.get("undefined"):
                continue
            if be.get("median") is None or fe.get("median") is None:
                continue
            if be.get("set_by_prior") or fe.get("set_by_prior"):
                continue                    # the prior's value is not a measurement
            sd = half_width(be)
            diff = fe["median"] - be["median"]
            diff = (diff + 180.0) % 360.0 - 180.0 if key == "azimuth_deg" else diff
            moved = diff / sd if sd > 0 else 0.0
            entry[key] = {"median": fe["median"], "ci95": fe["ci95"],
                          "fit_median": be["median"], "moved_sd": float(moved)}
        out[cid] = entry
    return out


#: How each estimate's move is written: its name and unit.
_MOVE_WORDS = {"azimuth_deg": ("azimuth", " deg"), "dip_deg": ("dip", " deg"),
               "period_s": ("period", " s"), "damping": ("damping", "")}


def moves_sentence(base_summary, final_summary):
    """One sentence on the estimates the final model moves from the base
    fit by more than :data:`MOVE_SD` of the fit's standard
    deviations (68 % half-width), largest first in those units: azimuths,
    dips, gains (in per cent of the fit's) and any other response parameter
    (a relative gain, the same move as its gain's, left out). None when
    nothing moves that far."""
    moves = sorted(((abs(v["moved_sd"]), cid, key, v)
                    for cid, entry in improved_estimates(base_summary, final_summary).items()
                    for key, v in entry.items() if key != "relative_gain"
                    and abs(v["moved_sd"]) > MOVE_SD), key=lambda m: (-m[0], m[1], m[2]))
    if not moves:
        return None
    parts = []
    for _, cid, key, v in moves:
        diff = v["median"] - v["fit_median"]
        if key == "azimuth_deg":
            diff = (diff + 180.0) % 360.0 - 180.0
        if key == "gain" and v["fit_median"]:
            name, size = "gain", f"{100 * diff / v['fit_median']:+.2g} %"
        else:
            name, unit = _MOVE_WORDS.get(key, (key.replace("_", " "), ""))
            size = f"{diff:+.3g}{unit}"
        parts.append(f"{cid}'s {name} by {size} ({abs(v['moved_sd']):.2g} sd)")
    return (f"it moves, largest first in the fit's standard deviations: {', '.join(parts)}; "
            f"no other estimate moves by more than {MOVE_SD:g} sd")
