"""Wrong-instrument metadata: does the criticism find a sensor's real
response when its StationXML names another instrument?

Four kinds, each on its own seeded pairs (seeds fixed here before any
result was seen: pair ``k`` of kind ``K`` uses ``seed = SEEDS[K] + k``):

* ``period``: the SUT's natural period is 2-4 times its metadata's (up or
  down; metadata 120 s, damping 0.707);
* ``damping``: its damping is 30 % above or below the metadata's;
* ``flat``: its metadata are ``flat`` (no response), the truth a
  two-pole broadband of period 60-360 s;
* ``extra_pz``: a real pole or zero in 1-50 Hz that the metadata lack.

Each pair (three components, sample rate and length per kind in
:data:`SETUP`, noise per kind in :data:`COUNTS_NOISE`) is fitted with :func:`bayescal.calibrate`
as a user runs it (``fit_response="gain"``: the fit holds period and
damping at the metadata's values; the criticism inside it, default budget). A pair passes when the
criticism names the response effect and the chosen model's 95 % interval
of each measured quantity (damping/period, and the period when the band
reaches the corner; the corner frequency of a pole or zero) holds the
truth. The coverage is judged against the binomial lower bound at 95 %
nominal coverage.

    python validation/studies/wrong_instrument.py [--n 30] [--kinds period,damping,flat,extra_pz]
        [--out validation/results/wrong_instrument.json]
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import binom

#: First seed of each kind (pair k uses SEEDS[kind] + k).
SEEDS = {"period": 41_000, "damping": 42_000, "flat": 43_000, "extra_pz": 44_000}
#: (duration s, sample rate Hz) per kind: long enough for the corner, fast
#: enough for the high-frequency pole or zero.
SETUP = {"period": (3600.0, 5.0), "damping": (3600.0, 5.0), "flat": (3600.0, 5.0),
         "extra_pz": (1200.0, 100.0)}
#: Self-noise white in counts per kind; the extra pole or zero's pairs have
#: noise shaped as the ground, so that the band chosen from the data reaches
#: the 1-50 Hz the pole or zero lies in (white noise in counts, at the
#: simulated levels, ends the coherent band near 1 Hz).
COUNTS_NOISE = {"period": True, "damping": True, "flat": True, "extra_pz": False}
NOMINAL = (120.0, 0.707, 750.0)
REF = (120.0, 0.707, 1500.0)


def draw(kind, k):
    """The truth of pair ``k`` of ``kind``: a dict with the SUT's true
    (period, damping), the metadata's, and any extra pole or zero."""
    rng = np.random.default_rng(SEEDS[kind] + k)
    t0, h = NOMINAL[0], NOMINAL[1]
    out = {"kind": kind, "seed": SEEDS[kind] + k, "metadata": [t0, h], "pz": None}
    if kind == "period":
        t0 = t0 * rng.uniform(2, 4) ** rng.choice([-1, 1])
    elif kind == "damping":
        h = h * (1 + 0.3 * rng.choice([-1, 1]))
    elif kind == "flat":
        t0 = float(np.exp(rng.uniform(np.log(60), np.log(360))))
        out["metadata"] = "flat"
    elif kind == "extra_pz":
        out["pz"] = (str(rng.choice(["pole", "zero"])), float(np.exp(rng.uniform(0, np.log(50)))))
    out["truth"] = [float(t0), float(h)]
    return out


def _filter(stream, which, fc, norm_freq=1.0):
    """Apply a real pole or zero at ``fc`` Hz (unit amplitude at
    ``norm_freq``) to every trace of ``stream`` in the frequency domain
    (the simulated records are periodic, so the filter is exact)."""
    for tr in stream:
        n = tr.stats.npts
        f = np.fft.rfftfreq(n, tr.stats.delta)
        h = (1 + 1j * f / fc) / abs(1 + 1j * norm_freq / fc)
        if which == "pole":
            h = 1 / h
        tr.data = np.fft.irfft(np.fft.rfft(tr.data) * h, n=n)
    return stream


def simulate(case):
    """The pair of ``case`` (:func:`draw`): (sut, sut metadata, ref, ref metadata)."""
    from bayescal.simulate import simulate_pair

    duration, fs = SETUP[case["kind"]]
    t0, h = case["truth"]
    sim = simulate_pair(duration=duration, fs=fs, seed=case["seed"],
                        sut_response=((t0, h, NOMINAL[2]),) * 3, nominal_response=NOMINAL,
                        ref_response=REF, noise_in_counts=COUNTS_NOISE[case["kind"]],
                        coherence=0.999)
    sut = sim.sut
    if case["pz"] is not None:
        sut = _filter(sut.copy(), *case["pz"])
    sut_xml = "flat" if case["metadata"] == "flat" else sim.sut_inventory
    return sut, sut_xml, sim.ref, sim.ref_inventory


def run_case(case, extract):
    """Fit one pair and judge it with ``extract(result, case) -> dict``."""
    import bayescal

    sut, sut_xml, ref, ref_xml = simulate(case)
    t = time.time()
    res = bayescal.calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml,
                             fit_response="gain", seed=0, progress=False)
    out = dict(case, seconds=time.time() - t, verdict=res.criticism.get("verdict"),
               headline=res.meta.headline,
               named=[e.get("name") for e in res.criticism.get("effects", [])])
    out.update(extract(res, case))
    return out


def binomial_floor(n, p=0.95, alpha=0.05):
    """Fewest of ``n`` intervals at nominal coverage ``p`` that a correct
    method reaches with probability at least 1 - ``alpha``."""
    k = 0
    while binom.cdf(k, n, p) < alpha:
        k += 1
    return k


#: The effects that carry the SUT's response as the data see it, by kind.
RESPONSE_EFFECTS = {"period": ("sut_corner", "response_parameters"),
                    "damping": ("sut_corner", "response_parameters"),
                    "flat": ("sut_corner",), "extra_pz": ("extra_pole",)}


def _holds(entry, value):
    lo, hi = entry["ci95"]
    return bool(lo <= value <= hi)


def judge(res, case):
    """Whether the response effect is named, and whether the chosen model's
    95 % intervals hold the truth: per SUT channel, damping/period, the
    period where the band reaches the corner, or the extra pole's or
    zero's corner frequency (a zero on the SUT is a pole on the reference
    to a pair)."""
    effects = [e for e in res.criticism.get("effects", [])
               if e.get("name") in RESPONSE_EFFECTS[case["kind"]]]
    out = {"response_named": bool(effects), "holds": {}, "values": {}}
    if not effects:
        return out
    t0, h = case["truth"]
    fmin, fmax = res.meta.band_hz if getattr(res.meta, "band_hz", None) else (None, None)
    if case["kind"] == "extra_pz":
        which, fc = case["pz"]
        want = "sut" if which == "pole" else "ref"
        for e in effects:
            # the summary's sentence says on which sensor the pole lies
            on = "ref" if e["explanation"].startswith("the reference's") else "sut"
            if on == want and "corner_hz" in e.get("size", {}):
                p = e["size"]["corner_hz"]
                out["values"]["corner_hz"] = [p["median"], *p["ci95"]]
                out["holds"]["corner_hz"] = _holds(p, fc)
        return out
    for cid in res.channel_ids:
        params = {}
        for e in effects:
            params.update({k.split(":")[0]: v for k, v in e.get("size", {}).items()
                           if isinstance(v, dict) and k.endswith(":" + cid)})
        if "damping_over_period" in params:
            p = params["damping_over_period"]
            out["values"][f"damping_over_period:{cid}"] = [p["median"], *p["ci95"]]
            out["holds"][f"damping_over_period:{cid}"] = _holds(p, h / t0)
        corner = 1.0 / t0
        if "period_s" in params and fmin is not None and corner >= fmin:
            p = params["period_s"]
            out["values"][f"period_s:{cid}"] = [p["median"], *p["ci95"]]
            out["holds"][f"period_s:{cid}"] = _holds(p, t0)
    return out


def summarise(rows, kinds):
    """Per kind: pairs, named, and per quantity the count of intervals that
    hold the truth against the binomial floor."""
    table = {}
    for kind in kinds:
        rs = [r for r in rows if r["kind"] == kind]
        named = sum(r["response_named"] for r in rs)
        qty = {}
        for r in rs:
            for k, ok in r["holds"].items():
                q = k.split(":")[0]
                qty.setdefault(q, []).append(ok)
        table[kind] = {"pairs": len(rs), "named": named,
                       "floor_named": binomial_floor(len(rs)),
                       "coverage": {q: {"held": int(sum(v)), "of": len(v),
                                        "floor": binomial_floor(len(v))}
                                    for q, v in qty.items()},
                       "seconds_median": float(np.median([r["seconds"] for r in rs]))
                       if rs else None}
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--start", type=int, default=0, help="first pair index")
    ap.add_argument("--kinds", default=",".join(SEEDS))
    ap.add_argument("--out", default="validation/results/wrong_instrument.json")
    a = ap.parse_args(argv)
    kinds = a.kinds.split(",")
    rows = []
    if os.path.exists(a.out):
        rows = json.load(open(a.out))["pairs"]
    done = {(r["kind"], r["seed"]) for r in rows}
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    for kind in kinds:
        for k in range(a.start, a.start + a.n):
            case = draw(kind, k)
            if (kind, case["seed"]) in done:
                continue
            r = run_case(case, judge)
            rows.append(r)
            print(f"{kind:9s} {k:3d} named={r['response_named']!s:5s} "
                  f"held={sum(r['holds'].values())}/{len(r['holds'])} {r['seconds']:.0f} s "
                  f"{r['verdict']} {r['named']}", flush=True)
            with open(a.out + ".tmp", "w") as fh:
                json.dump({"pairs": rows}, fh, indent=1, default=str)
            os.replace(a.out + ".tmp", a.out)
    table = summarise(rows, kinds)
    with open(a.out + ".tmp", "w") as fh:
        json.dump({"pairs": rows, "summary": table}, fh, indent=1, default=str)
    os.replace(a.out + ".tmp", a.out)
    print(json.dumps(table, indent=1))


if __name__ == "__main__":
    main()
