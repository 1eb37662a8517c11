"""What the criticism decides on the real recordings, for comparing two
source trees: every round's candidates with their BIC gains (or why one
was not scored), the effects kept and dropped, the named effects with
their channels, and the signatures' BIC gains (reference noise, clock
drift, orientation, tilt), of

* ObsPy's huddle pair as ``bayescal fit --fit-response gain --band 0.1 2``
  runs it (the criticism with its MCMC; examples/real_huddle.py's metadata),
* examples/diagnose_real.py's cases (the COWI pair as it is, with a hidden
  0.5 s clock offset and with LHE reversed; the huddle over 0.1-40 Hz),
  their Laplace approximation as the tests run them.

Needs ../shared/data. Run from the source tree to record (``PYTHONPATH``
that tree), then compare two records::

    PYTHONPATH=. python validation/studies/criticism_decisions.py --out a.json
    python validation/studies/criticism_decisions.py --compare a.json b.json

The comparison prints, per case, whether the rounds, kept, dropped and
named effects are the same, and the largest relative difference of the
BIC gains.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "real"


def _plain(o):
    if isinstance(o, dict):
        return {str(k): _plain(v) for k, v in o.items() if k not in ("fit", "seconds")}
    if isinstance(o, (list, tuple)):
        return [_plain(v) for v in o]
    if isinstance(o, np.ndarray):
        return _plain(o.tolist())
    if isinstance(o, np.generic):
        return o.item()
    return o


def _record(d, verdict=None):
    return {"steps": _plain(d.steps), "dropped": _plain(d.dropped), "verdict": verdict,
            "named": [[e["name"], e.get("channels")] for e in d.effects],
            "signatures": {k: v.get("delta_bic") for k, v in d.signatures.items()
                           if isinstance(v, dict) and "delta_bic" in v}}


def huddle_cli():
    """The huddle fit as the benchmark's command runs it, criticised."""
    import tempfile
    sys.path.insert(0, str(ROOT / "examples"))
    from real_huddle import write_inputs
    from bayescal import calibrate_files
    folder = DATA / "obspy_relcal"
    with tempfile.TemporaryDirectory() as tmp:
        ref_xml, sut_xml = write_inputs(folder, tmp)
        res = calibrate_files(ref=str(folder / "ref_STS2"), ref_xml=ref_xml,
                              sut=str(folder / "ref_unknown"), sut_xml=sut_xml,
                              fit_response="gain", band=(0.1, 2.0), progress=False)
    return res.criticism


def record():
    """{case: record} of every case."""
    import warnings
    sys.path.insert(0, str(ROOT / "examples"))
    from diagnose_real import CASES, run_case
    from bayescal.criticism import verdict as v
    seen = {}
    orig = v.criticise

    def keep(post, **kw):
        c = orig(post, **kw)
        seen["diagnosis"], seen["verdict"] = c.diagnosis, c.summary.get("verdict")
        return c
    v.criticise = keep
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        huddle_cli()
        d = seen["diagnosis"]
        out["huddle_cli"] = _record(d, seen["verdict"])
        for name, spec in CASES.items():
            import tempfile
            with tempfile.TemporaryDirectory() as tmp:
                d = run_case(name, spec, DATA, tmp, page=False, min_ess=200, n_tau=20)
            out[name] = _record(d)
    return out


def compare(a, b):
    """One line per case: same decisions, largest relative BIC difference."""
    for case in a:
        x, y = a[case], b.get(case)
        if y is None:
            print(f"{case}: missing in the second record")
            continue
        gains = [(s.get("delta_bic"), t.get("delta_bic")) for rx, ry in zip(x["steps"], y["steps"])
                 for s, t in zip(rx, ry)]
        gains += list(zip(x["signatures"].values(), y["signatures"].values()))
        rel = max((abs(p - q) / max(abs(p), 1e-300) for p, q in gains
                   if p is not None and q is not None), default=0.0)
        names = lambda r: [[(s.get("effect") or s.get("kept"), s.get("delta_bic") is None)
                            for s in st] for st in r["steps"]]
        same = (names(x) == names(y) and x["named"] == y["named"] and x["verdict"] == y["verdict"]
                and [d["effect"] for d in x["dropped"]] == [d["effect"] for d in y["dropped"]])
        print(f"{case}: same decisions {same}; named {[n for n, _ in y['named']]}; "
              f"verdict {y['verdict']}; largest relative BIC difference {rel:.1e}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", help="write this tree's record here")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"))
    a = ap.parse_args(argv)
    if a.compare:
        compare(*(json.loads(Path(p).read_text()) for p in a.compare))
        return 0
    if not DATA.is_dir():
        sys.exit(f"data folder {DATA} not found (see ../shared/data/README.md)")
    Path(a.out).write_text(json.dumps(record(), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
