"""Every stage of a pair fit within a work budget (bayescal.core.budget):
a least-squares run that ends by its budget stops at the best point it
evaluated; a fit whose stages all run out ends with a result and a line per
stage naming it and what helps, not an exception; a sampler whose first t
proposal fails fits it again after more DE steps instead of running the
DE moves' long chain."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from bayescal.core import Budget
from bayescal.core.budget import charge
from bayescal.core.fit.leastsq import solve
from bayescal.errors import NotConvergedWarning

#: A linear least-squares problem: its minimum in closed form.
A = np.array([[1.0, 0.0, 0.5], [0.2, 1.0, 0.0], [0.0, 0.3, 1.0], [1.0, 1.0, 1.0],
              [0.5, -1.0, 0.2]])
B = np.array([1.0, -2.0, 0.5, 3.0, 0.7])


def _counted(calls):
    def fun(x):
        charge(1)                     # one model evaluation, as a model's residual counts
        calls.append(np.array(x))
        return A @ x - B
    return fun


def test_least_squares_within_a_budget_ends_at_its_best_point():
    truth = np.linalg.lstsq(A, B, rcond=None)[0]
    calls = []
    free = solve(_counted(calls), np.zeros(3), method="lm", budget=Budget("least squares", 10**6))
    np.testing.assert_allclose(free.x, truth, atol=1e-7)
    assert free.status > 0
    calls = []
    budget = Budget("least squares", 3, helps="a narrower --band helps")
    res = solve(_counted(calls), np.zeros(3), method="lm", budget=budget)
    assert res.status == -3 and budget.ended_by == "work"
    assert len(calls) == 3 == budget.used             # no evaluation past the budget
    costs = [np.sum((A @ x - B) ** 2) for x in calls]
    np.testing.assert_array_equal(res.x, calls[int(np.argmin(costs))])
    assert res.message == ("least squares: ended by its work budget (3 model evaluations); "
                           "a narrower --band helps")


def test_work_counts_once_into_each_active_budget():
    outer, inner = Budget("fit", 100), Budget("mode search", 100)
    with outer.active(), inner.active(), inner.active():      # a stage inside a stage
        charge(5)
    charge(7)                                                  # none active: counted nowhere
    assert (outer.used, inner.used) == (5, 5)


@pytest.fixture(scope="module")
def small_files(tmp_path_factory):
    from bayescal.simulate.pair import simulate_pair
    folder = tmp_path_factory.mktemp("budget_pair")
    return simulate_pair(duration=1800.0, fs=5.0, seed=1).write(str(folder))


def test_spent_budgets_end_the_fit_with_a_result_and_say_which_stage(small_files, tmp_path,
                                                                     capfd, monkeypatch):
    from bayescal.cli import main
    from bayescal.core import budget

    monkeypatch.setattr(budget, "LEAST_SQUARES_WORK", 40)
    monkeypatch.setattr(budget, "MODE_SEARCH_WORK", 40)
    out = tmp_path / "out"
    code = main(["fit", "--ref", small_files["ref.mseed"], "--ref-xml", small_files["ref.xml"],
                 "--sut", small_files["sut.mseed"], "--sut-xml", small_files["sut.xml"],
                 "--band", "0.05", "1", "--no-report", "--no-diagnose", "--quiet",
                 "--max-steps", "20", "--out", str(out)])
    said = capfd.readouterr().out
    assert code == 3                                   # results written, chain unconverged
    for stage in ("least squares", "mode search"):
        assert (f"budget spent: {stage}: ended by its work budget (40 model evaluations); "
                "a narrower --band helps") in said, said
    assert "NOT CONVERGED: the sampler stopped" in said and "--max-steps" in said
    result = json.loads((out / "result.json").read_text())
    ended = {b["stage"]: b["ended_by"] for b in result["meta"]["budgets"]}
    assert ended == {"least squares": "work", "mode search": "work", "sampling": "work"}
    assert result["multimodal"]["not_tried"] > 0
    # the posterior of what was run holds the simulated axes (north, east)
    for cid, truth in (("XX.SIM.10.MH1", 0.0), ("XX.SIM.10.MH2", 90.0)):
        az = result["channels"][cid]["azimuth_deg"]
        lo, hi = az["ci95"]
        wrap = 360.0 if lo >= 180.0 else 0.0         # an interval written across north
        assert lo <= truth + wrap <= hi, (cid, az)


class FarStart:
    """A 3-D standard normal, its walkers started 100 sd away in a small
    ball: 100 DE steps do not bring them to it, 400 do."""

    ndim = 3

    def log_prob(self, x):
        x = np.atleast_2d(x)
        return -0.5 * np.sum(x * x, axis=1)


def test_a_second_adaptation_spares_the_de_moves_their_long_chain():
    """When the first t proposal accepts too rarely the DE moves run
    DE_RETRY more steps and the proposal is fitted again: the chain
    converges at the proposal's mixing and samples the target."""
    from bayescal.core.sampling import mcmc

    ch = mcmc.sample(FarStart(), np.array([100.0, 0.0, 0.0]), 0.01 * np.eye(3), seed=3,
                     progress=False)
    steps = [(p["label"], p["steps"]) for p in ch.sampler["phases"]]
    assert steps[:4] == [("burn-in, differential-evolution moves", mcmc.DE_BURN),
                         ("trial of the proposal fitted to the burn-in, accepted too rarely",
                          mcmc.ADAPT),
                         ("burn-in, differential-evolution moves", mcmc.DE_RETRY),
                         ("trial of the proposal fitted to the burn-in", mcmc.ADAPT)]
    assert ch.converged and ch.tau.max() < 3                  # the proposal's mixing
    se = 1.0 / np.sqrt(ch.ess)
    np.testing.assert_array_less(np.abs(ch.samples.mean(axis=0)), 4 * se)
    np.testing.assert_allclose(ch.samples.std(axis=0), 1.0, atol=4 * np.sqrt(0.5) * se.max())


def test_a_long_chain_keeps_at_most_max_kept_draws():
    """Thinning: a quarter of the smallest tau, and at least what keeps
    MAX_KEPT draws (memory of what is computed from the samples)."""
    from bayescal.core.sampling import mcmc

    assert mcmc._thin(np.array([20.0, 30.0]), 1000) == 5
    assert mcmc._thin(np.array([np.nan]), 10) == 1
    n = 4850 * 60                                          # a 60-walker chain run to its budget
    thin = mcmc._thin(np.array([3.2]), n)
    assert thin == 8 and n // thin <= mcmc.MAX_KEPT < n // (thin - 1)


class Banana:
    """A thin curved 2-D ridge: no t proposal fitted to it accepts often
    enough, so both adaptations fail and the DE moves carry on."""

    ndim = 2

    def log_prob(self, x):
        x = np.atleast_2d(x)
        return -0.5 * x[:, 0] ** 2 - 0.5 * ((x[:, 1] - 3.0 * x[:, 0] ** 2) / 0.05) ** 2


class Counting:
    """``target``'s log-probability, counting the points it is evaluated at."""

    def __init__(self, target):
        self.target, self.ndim, self.n = target, target.ndim, 0

    def log_prob(self, x):
        self.n += len(x)
        return self.target.log_prob(x)


@pytest.mark.parametrize("target, start, phases", [
    (FarStart(), [0.0, 0.0, 0.0], 3),                 # the proposal fits at once
    (FarStart(), [100.0, 0.0, 0.0], 5),               # one failed adaptation, then the proposal
    (Banana(), [0.0, 0.0], 5),                        # two failed adaptations: the DE moves
])
def test_the_sampling_budget_records_the_evaluations_made(monkeypatch, target, start, phases):
    """The sampling budget's ``used`` is every log-probability evaluation
    the sampler made (the walkers' start, each failed adaptation), counted
    outside it; within a work budget of 20,000 the default step limit keeps
    the work within it, and a chain that stops unconverged has spent it to
    its last whole step."""
    from bayescal.core.fit.run import _sampling_budget
    from bayescal.core.sampling import mcmc

    monkeypatch.setattr(mcmc, "SAMPLE_WORK", 20_000)
    counted = Counting(target)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotConvergedWarning)
        ch = mcmc.sample(counted, np.array(start), 0.01 * np.eye(target.ndim), seed=3,
                         progress=False)
    assert len(ch.sampler["phases"]) == phases
    rec = _sampling_budget(ch)
    assert rec["used"] == counted.n
    assert counted.n <= rec["limit"] <= 20_000
    if not ch.converged:
        assert counted.n > rec["limit"] - ch.n_walkers


def test_the_held_parameter_refit_ends_by_its_budget_and_says_so(small_files, tmp_path, capfd,
                                                                 monkeypatch):
    """A gain held at nominal (the hold forced here) and a refit budget of 5
    evaluations: the refit stops at its best point, meta.budgets records
    its 5 evaluations ended by work, and the console's line names the
    stage and the option that helps."""
    from bayescal.cli import main
    from bayescal.core import budget
    from bayescal.core.fit import unconstrained

    monkeypatch.setattr(budget, "LEAST_SQUARES_WORK", 40)
    monkeypatch.setattr(budget, "MODE_SEARCH_WORK", 40)
    monkeypatch.setattr(unconstrained, "REFIT_WORK", 5)
    monkeypatch.setattr(unconstrained, "early_holds", lambda model, theta: {
        next(j for j, n in enumerate(model.names) if n.endswith(":log_gain")): 0.6})
    out = tmp_path / "out"
    main(["fit", "--ref", small_files["ref.mseed"], "--ref-xml", small_files["ref.xml"],
          "--sut", small_files["sut.mseed"], "--sut-xml", small_files["sut.xml"],
          "--band", "0.05", "1", "--no-report", "--no-diagnose", "--quiet",
          "--fit-response", "all", "--max-steps", "20", "--out", str(out)])
    said = capfd.readouterr().out
    assert ("budget spent: refit with parameters held: ended by its work budget (5 model "
            "evaluations); fewer parameters help (--fit-response gain") in said, said
    result = json.loads((out / "result.json").read_text())
    refit = [b for b in result["meta"]["budgets"] if b["stage"] == "refit with parameters held"]
    assert refit and refit[0]["used"] == 5 and refit[0]["ended_by"] == "work"
