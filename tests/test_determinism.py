"""The same seed gives the same answer whatever the BLAS thread count.

One small simulated pair with one concealed effect (the SUT's clock 0.2 s
late, as ``tests/test_criticism.py`` builds it, 30 minutes at 5 Hz) is
fitted and criticised with the defaults in two fresh interpreters, one with
the BLAS libraries (OpenBLAS, OpenMP, MKL) allowed one thread, one allowed
two. The likelihood's linear algebra runs pinned to one thread
(:func:`bayescal.core.threads.single_threaded_blas`, around the least
squares, the sampler and the criticism's search); the criticism's search and
chain stop on a work budget (:mod:`bayescal.core.budget`), not a clock.
So the two runs must agree exactly: the least-squares point, every posterior
sample of the fit and of the improved model, the effects named, the work
spent. Exact equality is what is asserted (not a tolerance): every step is
seeded and the likelihood's products run on one thread. Without the pinning
the two runs differ (tried: the least squares then take other steps, and
the criticism's work differs, 12132 against 12136 evaluations).

The work budget itself, in process on the same pair: a model evaluation
counts one per parameter vector; the search stops on its work, not a clock;
the wall-clock safety net, when it ends the criticism, says so.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _digest(a):
    import numpy as np
    return hashlib.sha256(np.ascontiguousarray(a, dtype=float).tobytes()).hexdigest()


def run_once():
    """Fit and criticise the late-clock pair; print what the comparison
    reads as JSON (run in a subprocess by the test)."""
    import warnings

    import numpy as np
    from threadpoolctl import threadpool_info

    import bayescal
    from bayescal.core.threads import single_threaded_blas
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=5.0, seed=31, coherence=0.99,
                        sut_azimuth=(20.0, 110.0, 0.0), nominal_azimuth=(18.0, 108.0, 0.0),
                        timing_offset_s=0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                                  sut_xml=sim.sut_inventory, progress=False, min_ess=200,
                                  n_tau=20, band=(0.03, 2.0), seed=3)
    blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with single_threaded_blas():
        pinned = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    c = post.criticism or {}
    improved = getattr(post, "improved", None)
    out = {
        "blas_threads": blas, "blas_threads_pinned": pinned,
        "least_squares": {k: float(v) for k, v in post.meta.least_squares.items()},
        "samples": _digest(post.samples), "n_samples": int(len(post.samples)),
        "medians": np.median(post.samples, axis=0).tolist(),
        "effects": [e["name"] for e in c.get("effects", [])],
        "verdict": c.get("verdict"), "budget": c.get("budget"),
        "tried": c.get("tried"),
        "sizes": [e["size"] for e in c.get("effects", [])],
        "improved_samples": None if improved is None else _digest(improved.samples),
    }
    print(json.dumps(out))


def _start(threads):
    env = dict(os.environ, PYTHONHASHSEED="0", **{v: str(threads) for v in THREAD_VARS})
    return subprocess.Popen([sys.executable, "-c",
                             "from tests.test_determinism import run_once; run_once()"],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


@pytest.fixture(scope="module")
def runs():
    """Both interpreters run at once (each mostly on one core)."""
    procs = {n: _start(n) for n in (1, 2)}
    out = {}
    for n, p in procs.items():
        stdout, stderr = p.communicate(timeout=600)
        assert p.returncode == 0, stderr[-3000:]
        out[n] = json.loads(stdout.strip().splitlines()[-1])
    return out


def test_the_thread_limits_hold(runs):
    """The environment sets BLAS's threads (1 and 2: else the comparison
    below compares nothing), and the likelihood's pinning to one thread
    holds under either."""
    assert runs[1]["blas_threads"] and set(runs[1]["blas_threads"]) == {1}
    assert set(runs[2]["blas_threads"]) == {2}
    assert set(runs[1]["blas_threads_pinned"]) == set(runs[2]["blas_threads_pinned"]) == {1}


def test_one_seed_one_answer_on_one_or_two_blas_threads(runs):
    """The late clock is named in both runs, with the same size, from the
    same work; the fit's least-squares point and every sample of the fit's
    and of the improved model's posterior are bit for bit the same."""
    one, two = runs[1], runs[2]
    assert one["effects"] == ["timing_offset"]      # the concealed effect, so the check bites
    assert one["improved_samples"] is not None
    keys = ("effects", "verdict", "tried", "budget", "sizes", "least_squares", "samples",
            "medians", "improved_samples")
    assert [k for k in keys if one[k] != two[k]] == []


# --- the work budget, in process --------------------------------------------

def _late_pair():
    """A twenty-minute version of the pair, fitted without its criticism."""
    import warnings

    import bayescal
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1200.0, fs=5.0, seed=31, coherence=0.99,
                        sut_azimuth=(20.0, 110.0, 0.0), nominal_azimuth=(18.0, 108.0, 0.0),
                        timing_offset_s=0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                                  sut_xml=sim.sut_inventory, progress=False, min_ess=200,
                                  n_tau=20, band=(0.03, 2.0), seed=3, diagnose=False)


@pytest.fixture(scope="module")
def late_fit():
    return _late_pair()


def test_work_counts_one_per_model_evaluation(late_fit):
    """Seven parameter vectors evaluated at once are seven evaluations, into
    every active budget (an outer one too), and none outside them."""
    import numpy as np

    from bayescal.core.budget import Budget

    model, theta = late_fit.state.model, late_fit.state.theta_ls
    outer, inner = Budget("outer", 100), Budget("inner", 100)
    model.log_prob(np.repeat(theta[None], 3, axis=0))
    with outer.active():
        with inner.active():
            model.log_prob(np.repeat(theta[None], 7, axis=0))
        model.log_likelihood(theta[None])
    assert (inner.used, outer.used) == (7, 8)
    assert not inner.spent() and inner.remaining == 93


def test_the_search_stops_on_its_work_budget_not_a_clock(late_fit):
    """Budgets with no clock limit. One evaluation: the screens before the
    search spend it (``w0`` evaluations), no candidate is tried, the
    verdict is "unexplained" and the criticism incomplete, with no word of
    a time limit. ``w0 + 1``: the same screens cost the same ``w0`` (one
    seed, one count), the first candidate is tried (it costs more than one
    evaluation) and the search stops before the second."""
    from bayescal.core.budget import Budget
    from bayescal.criticism.verdict import criticise, lines

    c = criticise(late_fit.state, mcmc=False, budget=Budget("criticism", 1)).summary
    assert c["tried"] == [] and not c["complete"]
    assert c["verdict"] == "unexplained" and "criticism incomplete" in c["verdict_text"]
    assert c["budget"]["ended_by"] == "work" and c["budget"]["used"] > 1
    assert "budget_note" not in c and not any("time limit" in x for x in lines(c))
    w0 = c["budget"]["used"]
    c = criticise(late_fit.state, mcmc=False, budget=Budget("criticism", w0 + 1)).summary
    assert c["tried"] == ["timing_offset"] and not c["complete"]
    assert c["budget"]["ended_by"] == "work" and c["budget"]["used"] > w0 + 1


def test_the_time_limit_is_only_a_safety_net_and_says_so(late_fit):
    """Work to spare but the wall clock's safety net already passed: the
    criticism stops before its first candidate, and its output names the
    stage and that the time limit, not the work budget, ended it."""
    from bayescal.core.budget import Budget
    from bayescal.criticism.verdict import criticise, lines

    b = Budget("criticism", 10 ** 9, time_limit_s=0.0)
    c = criticise(late_fit.state, mcmc=False, budget=b).summary
    assert c["tried"] == [] and not c["complete"] and c["budget"]["ended_by"] == "time"
    note = "criticism: ended by its time limit (0 s, a safety net), not by its work budget"
    assert c["budget_note"].startswith(note)
    assert any(note in x for x in lines(c))
    assert "time limit" in c["verdict_text"]


def test_seconds_of_budget_translate_to_work():
    """``--diagnose-budget`` keeps its seconds: 60 of them are 60 times
    WORK_PER_SECOND evaluations, and the safety net ten times as long."""
    from bayescal.criticism.verdict import WORK_PER_SECOND, criticism_budget

    b = criticism_budget(60.0)
    assert (b.limit, b.time_limit_s, b.stage) == (60 * WORK_PER_SECOND, 600.0, "criticism")
