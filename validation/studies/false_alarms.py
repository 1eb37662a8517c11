"""False names on a second family of ground spectra.

The criticism (``bayescal fit``'s, with its default budget; the fit and the
improved model sampled to 200 effective samples) on pairs whose
ground motion is not the default simulator's: the steep-microseism family
(:mod:`bayescal.simulate.ground`: a steep fall below 0.05 Hz, microseism
peaks each arriving from three directions, Love waves, a 3-D isotropic
background). Each pair is 1800 s at 10 Hz, band 0.02-3 Hz, SUT coherence
drawn in 0.9-0.995, random azimuth, metadata within 3 degrees. Its noise
regime follows its seed: both sensors' self-noise white in counts (even
seeds) or shaped like the ground (odd seeds); the reference 100x quieter,
10x quieter or as noisy as the SUT (seed mod 3).

The criticism runs on every pair, whether or not the fit's model check
fails (``bayescal fit`` runs it only when the check fails; the table
counts both).

* 60 clean pairs (seeds :data:`CLEAN_SEEDS`): a name is a false alarm;
  acceptance: at most 1.
* 60 single-effect pairs (seeds :data:`EFFECT_SEEDS`, one effect of the
  harness's catalogue each, :func:`bayescal.simulate.harness.draw_effect`):
  an extra name is one other than the hidden effect's; acceptance: extra
  names on at most 5 % of the pairs (3 of 60).

The seeds were written here before any result was seen.

    python validation/studies/false_alarms.py --out validation/results/diagnose/false_alarms.json
    python validation/studies/false_alarms.py --noise-shapes signal --out validation/results/diagnose/false_alarms_signal_only.json
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

import study_results                          # the sibling module, run as a script

from bayescal.criticism import tilt
from bayescal.simulate.harness import concealed_pair

#: Seeds fixed before the study was run.
CLEAN_SEEDS = tuple(range(4000, 4060))
EFFECT_SEEDS = tuple(range(5000, 5060))
BAND = (0.02, 3.0)
GROUND = "steep-microseism"
DURATION, FS = 1800.0, 10.0
REFERENCES = ("default", "ref10x", "equal")


def run_one(seed, clean):
    """One pair through the fit (:func:`bayescal.pair.prepare`,
    :func:`~bayescal.pair.fitting.fit`) and the criticism with its default
    budget (:func:`bayescal.criticism.verdict.criticise`), run whether or not
    the fit's model check fails (``bayescal fit`` runs it only when it
    fails: ``check_ok`` says which); returns its record."""
    from bayescal.criticism.verdict import criticise
    from bayescal.errors import InputError
    from bayescal.pair import prepare
    from bayescal.pair.fitting import fit

    regime = REFERENCES[seed % 3]
    run = concealed_pair(seed, 1.0 if clean else 0.0, regime, ground=GROUND, duration=DURATION,
                         fs=FS, counts=seed % 2 == 0)
    sim = run.sim
    rec = {"seed": seed, "truth": run.kind, "truth_size": run.truth, "regime": regime,
           "noise": "counts" if seed % 2 == 0 else "ground", "coherence": run.coherence}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = prepare(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                           sut_xml=sim.sut_inventory, band=BAND)
            state = fit(data, seed=seed, progress=False, min_ess=200, n_tau=20)
            crit = criticise(state, seed=seed, min_ess=200, n_tau=20)
    except InputError as exc:
        return dict(rec, named=[], extra=[], outcome="refused", refusal=str(exc),
                    seconds=time.perf_counter() - t0)
    c = crit.summary or {}
    names = [e["name"] for e in c.get("effects", [])]
    extra = [n for n in names if n != run.kind]
    d, sp = crit.diagnosis, state.model.spectra
    t = d.signatures.get("tilt_noise") if d is not None else None
    check_ok = bool(state.summary().get("adequacy", {}).get("ok"))
    rec.update(named=names, extra=extra, verdict=c.get("verdict"), check_ok=check_ok,
               named_by_fit=[] if check_ok else names,
               misfit_before=c.get("misfit_before"), misfit_after=c.get("misfit_after"),
               dropped=d.dropped if d is not None else [],
               tilt={k: t.get(k) for k in ("delta_bic", "kept", "noise_shape", "n_data",
                                           "dropped")} if t else None,
               n_search=2 * sp.n_bands * sp.n_u * sp.n_r,
               seconds=time.perf_counter() - t0,
               outcome=("false alarm" if names else "clean") if clean
               else ("extra name" if extra else "no extra name"))
    return rec


def design_rate(n_tilt=57, n_search=216, k_search=(1, 1, 1, 1), bic_keep=10.0):
    """The per-pair false-alarm rate BIC_KEEP implies, by Wilks's theorem:
    a nested extension with ``k`` parameters on ``n`` data is kept when
    ``dchi2 > bic_keep + k ln n``, and under its null ``dchi2 ~ chi2(k)``.
    The tilt test: ``k = 3`` on ``n_tilt`` data; the search: one test per
    candidate (``k_search``: timing offset, clock drift, an extra pole on
    the SUT, one on the reference) on ``n_search`` real residual entries; the pair's rate at
    most their sum (Bonferroni). Returns a dict."""
    from scipy.stats import chi2

    tilt = float(chi2.sf(bic_keep + 3 * np.log(n_tilt), 3))
    search = [float(chi2.sf(bic_keep + k * np.log(n_search), k)) for k in k_search]
    return {"tilt": tilt, "search": search, "pair": tilt + sum(search),
            "n_tilt": n_tilt, "n_search": n_search, "bic_keep": bic_keep}


def binomial_bound(p, n=60, allowed=1):
    """P(more than ``allowed`` false alarms in ``n`` pairs) at per-pair rate ``p``."""
    from scipy.stats import binom
    return float(binom.sf(allowed, n, p))


def table(records):
    """Rows of (set, pairs, refused, checks failed, pairs with a false name
    (criticism on every pair), the same where the check failed, the false
    names)."""
    rows = []
    for label, clean in (("clean", True), ("single effect", False)):
        rs = [r for r in records if (r["truth"] == "none") == clean]
        done = [r for r in rs if r["outcome"] != "refused"]
        bad = [r for r in done if r["outcome"] in ("false alarm", "extra name")]
        what = sorted({n for r in bad for n in (r["named"] if clean else r["extra"])})
        rows.append((label, len(rs), len(rs) - len(done), sum(not r["check_ok"] for r in done),
                     len(bad), sum(not r["check_ok"] for r in bad), ", ".join(what) or "-"))
    return rows


def details(records):
    """What the page says of single pairs: per hidden effect, the pairs
    where it is named (of those drawn); the hidden tilts not named (level,
    noise shape); each clean pair with a name (seed, reference, noise
    shape, SUT coherence, names, whether its check passed)."""
    done = [r for r in records if r["outcome"] != "refused"]
    named = {}
    for r in done:
        if r["truth"] != "none":
            d = named.setdefault(r["truth"], {"named": 0, "of": 0})
            d["of"] += 1
            d["named"] += r["truth"] in r["named"]
    missed_tilts = [{"seed": r["seed"], "level": r["truth_size"]["level"], "noise": r["noise"]}
                    for r in done if r["truth"] == "tilt_noise" and "tilt_noise" not in r["named"]]
    clean_named = [{"seed": r["seed"], "regime": r["regime"], "noise": r["noise"],
                    "coherence": r["coherence"], "named": r["named"], "check_ok": r["check_ok"]}
                   for r in done if r["truth"] == "none" and r["named"]]
    return {"named_by_effect": named, "missed_tilts": missed_tilts, "clean_named": clean_named}


def summary_from_runs(out):
    """Write ``out``'s summary again from its per-run records (``out``'s
    ``.runs.json``), :func:`details` included."""
    doc = study_results.read(out)
    doc["details"] = details(doc["runs"])
    study_results.write(out, doc)
    return doc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation/results/diagnose/false_alarms.json")
    ap.add_argument("--first", type=int, default=0, help="skip this many pairs of each set")
    ap.add_argument("--pairs", type=int, default=60, help="pairs of each set")
    ap.add_argument("--noise-shapes", nargs="+", choices=tilt.NOISE_SHAPES,
                    default=list(tilt.NOISE_SHAPES),
                    help="the self-noise shapes the tilt test judges against ('signal' "
                         "alone: the test without the sensor's own noise shape)")
    ap.add_argument("--summarise", action="store_true",
                    help="write OUT's summary again from its per-run records (OUT's .runs.json)")
    args = ap.parse_args(argv)
    if args.summarise:
        print(summary_from_runs(args.out)["details"])
        return
    tilt.NOISE_SHAPES = tuple(args.noise_shapes)
    sl = slice(args.first, args.first + args.pairs)
    jobs = [(s, True) for s in CLEAN_SEEDS[sl]] + [(s, False) for s in EFFECT_SEEDS[sl]]
    records, t0 = [], time.perf_counter()
    for k, (seed, clean) in enumerate(jobs):
        rec = run_one(seed, clean)
        records.append(rec)
        study_results.checkpoint(args.out, {"runs": records})
        print(f"{k + 1:3d} seed {seed} {rec['truth']:18s} {rec['regime']:8s} {rec['noise']:6s} "
              f"-> {rec['outcome']:13s} {rec['named']} {rec['seconds']:.1f} s",
              file=sys.stderr, flush=True)
    done = [r for r in records if r["outcome"] != "refused"]
    n_tilt = [r["tilt"]["n_data"] for r in done if r.get("tilt") and r["tilt"].get("n_data")]
    rate = design_rate(int(np.median(n_tilt)) if n_tilt else 57,
                       int(np.median([r["n_search"] for r in done])) if done else 216)
    lines = ["| pairs | drawn | refused | check failed | with a false name | of them, check "
             "failed | false names |", "|---|---|---|---|---|---|---|"]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in table(records)]
    lines.append("")
    lines.append(f"design false-alarm rate per pair (Wilks, BIC_KEEP {rate['bic_keep']:g}): tilt "
                 f"{rate['tilt']:.2g}, search candidates {', '.join(f'{x:.2g}' for x in rate['search'])}; "
                 f"at most {rate['pair']:.2g} a pair; P(more than 1 of 60) = "
                 f"{binomial_bound(rate['pair']):.2g}; {time.perf_counter() - t0:.0f} s in all")
    text = "\n".join(lines)
    print(text)
    study_results.write(args.out, {"runs": records, "design": rate, "table": text,
                                   "details": details(records),
                                   "settings": {"band": BAND, "ground": GROUND,
                                                "noise_shapes": list(tilt.NOISE_SHAPES),
                                                "duration_s": DURATION, "fs": FS}})


if __name__ == "__main__":
    main()
