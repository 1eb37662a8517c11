"""emcee samples every posterior (:mod:`bayescal.core.sampling.mcmc`): a chain is
emcee's own chain for the same moves and seed, the same seed gives the same
chain, what was run is recorded, the convergence rule has a known answer,
and a chain that reaches ``max_steps`` says so where a user looks (the
Python warning, result.json, the console line and exit code 3)."""
from __future__ import annotations

import json
import subprocess
import sys

import emcee
import numpy as np
import pytest

from bayescal.core.sampling import mcmc
from bayescal.errors import NotConvergedWarning
from tests.conftest import SIM_BAND


class Gaussian:
    """A correlated 4-D Gaussian target."""

    ndim = 4
    cov = np.array([[1.0, 0.6, 0.0, 0.1], [0.6, 2.0, 0.3, 0.0], [0.0, 0.3, 0.5, 0.0],
                    [0.1, 0.0, 0.0, 3.0]])

    def log_prob(self, x):
        x = np.atleast_2d(x)
        return -0.5 * np.einsum("wi,ij,wj->w", x, np.linalg.inv(self.cov), x)


def test_de_chain_is_emcees_own():
    """move="de": the kept samples are those of an emcee.EnsembleSampler with
    DEMove 0.8 / DESnookerMove 0.2, seeded the same, run as many steps."""
    t = Gaussian()
    ch = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=5, progress=False, move="de")
    p0 = np.random.default_rng(5).multivariate_normal(np.zeros(4), 0.1 * t.cov, size=32)
    ref = emcee.EnsembleSampler(32, 4, t.log_prob, vectorize=True,
                                moves=[(emcee.moves.DEMove(), 0.8),
                                       (emcee.moves.DESnookerMove(), 0.2)])
    ref.random_state = np.random.RandomState(5).get_state()
    ref.run_mcmc(p0, ch.n_steps)
    thin = max(1, int(ch.tau.min() / 4))
    np.testing.assert_array_equal(ch.samples, ref.get_chain(discard=ch.burn, thin=thin,
                                                            flat=True))
    np.testing.assert_array_equal(ch.tau, emcee.autocorr.integrated_time(
        ref.get_chain(discard=ch.burn), tol=0))
    assert ch.acceptance == pytest.approx(np.mean(ref.acceptance_fraction))
    rec = ch.sampler
    assert rec["library"] == "emcee" and rec["version"] == emcee.__version__
    assert rec["walkers"] == 32 and rec["steps"] == ch.n_steps
    assert [m["move"] for m in rec["phases"][0]["moves"]] == ["DEMove", "DESnookerMove"]
    assert [m["weight"] for m in rec["phases"][0]["moves"]] == [0.8, 0.2]
    # the chain samples the target: variances within 5 standard errors
    se = np.diag(t.cov) * np.sqrt(2 / ch.ess)
    assert np.all(np.abs(ch.samples.var(axis=0) - np.diag(t.cov)) < 5 * se)


def test_independence_phases_recorded_and_reproducible():
    t = Gaussian()
    a = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=2, progress=False, move="independence")
    b = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=2, progress=False, move="independence")
    c = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=3, progress=False, move="independence")
    np.testing.assert_array_equal(a.samples, b.samples)
    assert a.samples.shape != c.samples.shape or not np.array_equal(a.samples, c.samples)
    phases = a.sampler["phases"]
    assert [p["steps"] for p in phases[:2]] == [mcmc.DE_BURN, mcmc.ADAPT]
    assert phases[-1]["moves"][0]["move"].startswith("IndependenceMove")
    assert sum(p["steps"] for p in phases) == a.n_steps == a.sampler["steps"]
    assert phases[-1]["acceptance"] == pytest.approx(a.acceptance)
    assert 0.3 < a.acceptance <= 1.0       # the frozen t proposal fits this target


def test_split_rhat_known_answer():
    """Two halves with equal variance W and means d apart, each counted as
    n = ess / 2 draws: BDA3 eqs. 11.3-11.4 give B = n d^2 / 2 and
    R = sqrt((n - 1) / n + d^2 / (2 W))."""
    base = np.tile([-1.0, 1.0, -2.0, 2.0], 50)              # 200 draws, mean 0
    for d, ess in ((0.0, 400.0), (0.3, 400.0), (1.0, 50.0)):
        chain = np.concatenate([base, base + d])[:, None, None]
        n, w = ess / 2, base.var(ddof=1)
        want = np.sqrt((n - 1) / n + d * d / (2 * w))
        np.testing.assert_allclose(mcmc.split_rhat(chain, np.array([ess])), want, rtol=1e-12)


def test_rule_met_or_stopped_at_max_steps():
    t = Gaussian()
    ok = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=1, progress=False, move="de")
    kept = ok.n_steps - ok.burn
    assert ok.converged and kept >= 50 * ok.tau.max() and ok.ess.min() >= 1000
    assert ok.rhat.max() < 1.01
    for move, pre in (("de", 0), ("independence", mcmc.DE_BURN + mcmc.ADAPT)):
        with pytest.warns(NotConvergedWarning, match="stopped at"):
            ch = mcmc.sample(t, np.zeros(4), 0.1 * t.cov, seed=1, progress=False, move=move,
                             max_steps=40)
        assert not ch.converged and ch.n_steps == pre + 40
        assert ch.summary()["converged"] is False and ch.samples.shape[0] > 0


def test_cli_unconverged_says_so_and_exits_3(sim_files, tmp_path):
    out = tmp_path / "out"
    args = ["--ref", sim_files["ref.mseed"], "--ref-xml", sim_files["ref.xml"], "--sut",
            sim_files["sut.mseed"], "--sut-xml", sim_files["sut.xml"], "--band", *SIM_BAND]
    proc = subprocess.run([sys.executable, "-m", "bayescal", "fit", *map(str, args), "--out",
                           str(out), "--quiet", "--no-report", "--max-steps", "20"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 3, proc.stderr
    lines = [ln for ln in proc.stdout.splitlines() if "NOT CONVERGED" in ln]
    steps = mcmc.ADAPT + 20      # a pair fit's Laplace trial (its burn-in) and 20 kept
    assert len(lines) == 1 and f"stopped at {steps} steps" in lines[0], proc.stdout
    assert "Warning" not in proc.stderr and "Traceback" not in proc.stderr
    res = json.loads((out / "result.json").read_text())
    assert res["convergence"]["converged"] is False
    assert res["meta"]["sampler"]["library"] == "emcee"
    for cmd in ("fit", "diagnose", "cal", "uvw"):
        helptext = subprocess.run([sys.executable, "-m", "bayescal", cmd, "--help"],
                                  capture_output=True, text=True).stdout
        assert "3 results written" in " ".join(helptext.split()), cmd


def test_independence_move_accepts_everything_when_the_target_is_its_proposal():
    """Acceptance is min(1, pi(q) g(x) / (pi(x) g(q))): with pi = g every
    proposal is accepted, at every step of a batched run (a wrong log g at
    the walkers' positions, or a proposal paired with another's
    log-probability, would reject some)."""
    prop = mcmc.TProposal(np.array([0.5, -1.0, 2.0]), Gaussian.cov[:3, :3])

    class Target:
        ndim = 3

        def log_prob(self, x):
            return prop.log_pdf(x) + 7.0

    move = mcmc.IndependenceMove(prop)
    s = mcmc.VectorSampler(16, 3, Target().log_prob, moves=[move])
    s.random_state = np.random.RandomState(1).get_state()
    state = s.run_mcmc(np.random.default_rng(1).standard_normal((16, 3)), 1)
    move.plan(37)                                   # a batched run (the last step alone)
    s.run_mcmc(state, 38)
    assert np.all(s.acceptance_fraction == 1.0)
    assert len(np.unique(s.get_chain()[:, 0, 0])) == 39      # a new point every step


def test_chain_convergence_is_the_result_container():
    """A chain's convergence is the frozen container a result holds: the
    same arrays and run size, and its summary is the chain's."""
    from bayescal.result.convergence import Convergence

    ch = mcmc.Chain(samples=np.zeros((4, 2)), log_prob=np.zeros(4), tau=np.array([2.0, 5.0]),
                    ess=np.array([700.0, 300.0]), rhat=np.array([1.01, 1.002]), acceptance=0.3,
                    n_steps=900, n_walkers=8, burn=120, converged=True, trace=np.zeros((1, 8, 2)))
    conv = ch.convergence()
    assert isinstance(conv, Convergence)
    assert (conv.burn, conv.n_steps, conv.n_walkers, conv.ess_min) == (120, 900, 8, 300.0)
    assert ch.summary() == {"ess_min": 300.0, "tau_max": 5.0, "rhat_max": 1.01, "n_steps": 900,
                            "n_walkers": 8, "acceptance": 0.3, "converged": True}


def test_laplace_trial_replaces_the_burn_in_and_samples_the_target():
    """sample(laplace=True) from the target's own mean and covariance: the
    trial of the t proposal around them accepts, no DE step runs, and the
    kept draws have the target's mean and covariance (4 Monte Carlo errors)."""
    t = Gaussian()
    ch = mcmc.sample(t, np.zeros(4), t.cov, seed=2, progress=False, laplace=True)
    phases = ch.sampler["phases"]
    assert [(p["label"], p["steps"]) for p in phases[:1]] == [(mcmc.LAPLACE_TRIAL, mcmc.ADAPT)]
    assert phases[0]["acceptance"] >= mcmc.LAPLACE_ACCEPTANCE
    assert not any("differential-evolution" in p["label"] for p in phases)
    assert ch.converged and ch.n_steps == sum(p["steps"] for p in phases)
    se = np.sqrt(np.diag(t.cov) / ch.ess)
    np.testing.assert_array_less(np.abs(ch.samples.mean(axis=0)), 4 * se)
    np.testing.assert_allclose(ch.samples.std(axis=0), np.sqrt(np.diag(t.cov)),
                               atol=4 * np.sqrt(0.5) * se.max() * np.sqrt(np.diag(t.cov)).max())


def test_a_poor_laplace_trial_leaves_the_de_burn_in_as_without_it():
    """Started 30 sd off in a small ball, the Laplace trial accepts too
    rarely: the DE burn-in then runs from the walkers' start with the same
    random stream, so the chain is the one sample(laplace=False) gives."""
    t = Gaussian()
    start, cov = np.array([30.0, 0.0, 0.0, 0.0]), 0.01 * np.eye(4)
    ch = mcmc.sample(t, start, cov, seed=4, progress=False, laplace=True)
    plain = mcmc.sample(t, start, cov, seed=4, progress=False)
    first = ch.sampler["phases"][0]
    assert first["label"] == f"{mcmc.LAPLACE_TRIAL}, accepted too rarely"
    assert first["acceptance"] < mcmc.LAPLACE_ACCEPTANCE
    assert ch.sampler["phases"][1:] == plain.sampler["phases"]
    np.testing.assert_array_equal(ch.samples, plain.samples)
    # the trial's cost: its steps and the walkers' start, evaluated by its sampler
    extra = (mcmc.ADAPT + 1) * 32
    assert ch.converged and ch.sampler["evaluations"] == plain.sampler["evaluations"] + extra
