"""Same estimates from two source trees: seeded pair fits in each, compared.

The pair is ``benchmarks/bench_process.py``'s 2-hour 20-Hz 3+3 simulated
pair (its ``DEMO_TRUTH``), fitted with seeds 0 .. ``--seeds`` - 1, no
criticism, each in a fresh subprocess per tree. Deterministic values (the
least-squares point, the reference's noise coefficients and inflation, the
plug-in precision's sum, the log-posterior differences of the modes both
trees list) are compared by their largest difference over the seeds,
relative and, for the least-squares point, absolute; the modes one tree
lists and the other does not, and each fit's count of starts run off
their chart, are listed. The sampled medians are compared as two
independent Monte Carlo estimates: ``z = (m_a - m_b) / sqrt(e_a^2 + e_b^2)``,
``e`` a median's Monte Carlo error (``sqrt(pi / 2)`` sd over the square root
of the chain's smallest ESS, which overstates it for the other
parameters). Where the sampler is unchanged the chains are the same and
every ``z`` is 0; where it changed, the two trees sample the same
posterior when the ``z`` are standard normal or narrower: the count of
``|z| > 2`` is set against its binomial tail at 4.55 % (a smaller count
than chance is what the conservative ESS gives).

    python validation/studies/same_estimates.py --before /work/main [--seeds 5]
        [--out validation/results/speed/same_estimates.json]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.stats import binom

ROOT = Path(__file__).resolve().parents[2]

FIT = """
import json, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
from bayescal.pair.workflow import calibrate_files
d = sys.argv[1]
r = calibrate_files(ref=d + "/ref.mseed", ref_xml=d + "/ref.xml", sut=d + "/sut.mseed",
                    sut_xml=d + "/sut.xml", seed=int(sys.argv[3]), progress=False,
                    diagnose=False)
s, m = r.summary(), r.state.model
json.dump({"least_squares": s["meta"]["least_squares"],
           "noise_inflation": list(map(float, s["meta"]["noise_inflation"])),
           "noise_rho": np.asarray(m.noise.rho).tolist(),
           "noise_W_sum": float(np.sum(m.noise.W)),
           "modes": [[x["start"], x["log_posterior_difference"]]
                     for x in s["multimodal"]["modes"]],
           "off_chart": s["multimodal"].get("off_chart", 0),
           "channels": s["channels"], "ess_min": s["convergence"]["ess_min"]},
          open(sys.argv[2], "w"), default=float)
"""


def _fit(tree, folder, out, seed):
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", FIT, folder, out, str(seed)], env=env, check=True,
                   cwd=folder)
    with open(out) as fh:
        return json.load(fh)


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-300)))


def _medians(a, b):
    """{channel quantity: z of the two medians' difference} (module docstring)."""
    out = {}
    for cid, ch in a["channels"].items():
        for name, e in list(ch.items()) + list(ch.get("response", {}).items()):
            if isinstance(e, dict) and e.get("median") is not None:
                e2 = b["channels"][cid].get(name) or b["channels"][cid]["response"][name]
                err = np.sqrt(np.pi / 2 * (e["sd"] ** 2 / a["ess_min"]
                                           + e2["sd"] ** 2 / b["ess_min"]))
                out[f"{cid} {name}"] = (e["median"] - e2["median"]) / err
    return out


def _modes(a, b):
    """Largest difference of the log-posterior differences of the modes both
    fits list (by their start; a start one tree lists and the other does
    not is kept apart, :func:`compare`)."""
    ma, mb = dict(a["modes"]), dict(b["modes"])
    return max(abs(ma[k] - mb[k]) for k in ma if k in mb)


def compare(pairs):
    """The differences the module docstring lists over ``pairs``, each
    ``(a, b)`` one seed's fits, ``a`` the reference tree's."""
    worst = {}
    for a, b in pairs:
        names = list(a["least_squares"])
        la, lb = (np.array([x["least_squares"][n] for n in names]) for x in (a, b))
        for key, v in (("least_squares_max_abs", float(np.max(np.abs(la - lb)))),
                       ("least_squares_max_rel", _rel(la, lb)),
                       ("noise_inflation_max_rel", _rel(a["noise_inflation"],
                                                        b["noise_inflation"])),
                       ("noise_rho_max_rel", _rel(a["noise_rho"], b["noise_rho"])),
                       ("noise_W_sum_rel", _rel(a["noise_W_sum"], b["noise_W_sum"])),
                       ("modes_log_posterior_max_abs", _modes(a, b))):
            worst[key] = max(worst.get(key, 0.0), v)
    z = np.array([v for a, b in pairs for v in _medians(a, b).values()])
    over = int(np.sum(np.abs(z) > 2))
    only = {"before": [m for a, b in pairs for m in a["modes"] if m[0] not in dict(b["modes"])],
            "after": [m for a, b in pairs for m in b["modes"] if m[0] not in dict(a["modes"])]}
    return {**worst, "modes": {"before": pairs[0][0]["modes"], "after": pairs[0][1]["modes"]},
            "modes_in_one_tree_only": only,
            "off_chart": {"before": [a.get("off_chart", 0) for a, _ in pairs],
                          "after": [b.get("off_chart", 0) for _, b in pairs]},
            "median_z": {"n": int(z.size), "max_abs": float(np.max(np.abs(z))),
                         "sd": float(np.sqrt(np.mean(z ** 2))), "over_2": over,
                         "p_at_least_that_many_by_chance": float(binom.sf(over - 1, z.size,
                                                                          0.0455))}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the other source tree")
    ap.add_argument("--seeds", type=int, default=5, help="fits per tree (seeds 0 .. N-1)")
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "speed"
                                         / "same_estimates.json"))
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    sys.path.insert(0, str(ROOT))
    from bench_process import DEMO_TRUTH

    from bayescal.simulate.pair import simulate_pair
    pairs = []
    with tempfile.TemporaryDirectory() as tmp:
        simulate_pair(**DEMO_TRUTH).write(tmp)
        for seed in range(a.seeds):
            pairs.append(tuple(_fit(tree, tmp, os.path.join(tmp, f"{name}.json"), seed)
                               for name, tree in (("before", a.before), ("after", ROOT))))
    result = {"command": "python validation/studies/same_estimates.py "
                         + " ".join(argv or sys.argv[1:]), "seeds": a.seeds, **compare(pairs)}
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(result, fh, indent=1)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
