"""Every MCMC posterior of bayescal is sampled here, by emcee.

:func:`sample` starts, runs and checks every chain (pair fits, a diagnosis's
final model, coil elements, step and sine runs, UVW): an
:class:`emcee.EnsembleSampler` (``vectorize=True``, one log-probability call
per sub-ensemble or per step) driven in phases, each phase a new sampler
started from the last :class:`emcee.State` of the one before, with the
random stream handed on:

* ``move="de"``: emcee's ``DEMove`` (weight 0.8) and ``DESnookerMove``
  (weight 0.2) throughout;
* ``move="independence"`` (the default, every posterior of bayescal):
  :data:`DE_BURN` steps of those moves
  find the posterior's scale (:data:`DE_RETRY` more when the first
  proposal accepts too rarely); then :class:`IndependenceMove`, an
  :class:`emcee.moves.Move` whose proposal is a multivariate Student t
  fitted to the DE draws (:class:`TProposal`), runs :data:`ADAPT` steps, is
  refitted to them and frozen for the kept chain. On the near-Gaussian
  posteriors of pair and coil fits it mixes in one or two steps where the
  DE moves need 10-40. If it accepts less than :data:`MIN_ACCEPTANCE` (a posterior
  far from Gaussian), the DE sampler carries on from its burn-in instead.
  With ``laplace=True`` (pair fits, which start from a least-squares point
  and its Laplace covariance) a trial of the t proposal around that point
  comes first; where it accepts at least :data:`LAPLACE_ACCEPTANCE` it
  takes the DE burn-in's place (100 steps of DE moves cost as much as the
  kept chain of a pair fit), else the DE burn-in runs as above.

Convergence rule (all must hold, checked after every chunk of steps):

* at least ``n_tau`` (50) integrated autocorrelation times of kept chain for
  the slowest parameter (tau from :func:`emcee.autocorr.integrated_time`,
  averaged over walkers);
* at least ``min_ess`` (1000) effective samples for every parameter;
* split R-hat below ``rhat_max`` (1.01) between the two halves of the kept
  chain (:func:`split_rhat`). Walkers of one ensemble are not independent,
  so R-hat across walkers would not be valid; each half counts its effective
  (not raw) draws.

A chain that reaches ``max_steps`` first is returned with
``converged=False`` and a :class:`NotConvergedWarning`. What was run (emcee's
version, the walkers, each phase's moves with their weights, steps and
acceptance) is in :attr:`Chain.sampler`.

``import emcee`` imports scipy.stats (through its KDE move), about 0.4-1 s:
this module is imported only by code that samples.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import emcee
import numpy as np

from ...errors import NotConvergedWarning
from ...result.convergence import Convergence
from ..budget import SAMPLE_WORK
from ..posterior.convergence import not_converged_line
from .display import progress_display
from .independence import IndependenceMove, TProposal

#: ``move="independence"``: DE steps before the first proposal is fitted (from
#: their second half), independence steps before it is refitted, and the
#: acceptance below which the DE moves carry on instead.
DE_BURN, ADAPT, MIN_ACCEPTANCE = 100, 50, 0.2
#: DE steps run once more, and the proposal fitted again, when the first
#: adaptation accepts less than :data:`MIN_ACCEPTANCE`: walkers started from
#: the least-squares Laplace approximation on a skewed ridge (a prior against
#: the data: a 40-s sensor whose metadata say 120 s, ``--fit-response all``)
#: have not settled in :data:`DE_BURN` steps; fitted after 400 the proposal
#: accepts 0.45 and the chain converges in 650 steps, where the DE moves
#: alone (tau about 40) need 2600 (docs/validation/speed.md, "Awkward inputs").
DE_RETRY = 300
#: Most draws a chain keeps (thinned further beyond it): what is computed
#: from the samples (responses, prior sensitivity, the summaries) grows with
#: them; a chain run to its work budget at a tau of 3 kept 290,000 draws of
#: 15 parameters and took 1.6 GB (docs/validation/speed.md, "Awkward inputs").
MAX_KEPT = 40_000
#: ``sample(..., laplace=True)``: the phase that tries the t proposal around
#: the start and covariance given, and the acceptance it must reach to be
#: kept (where the Laplace approximation is poor, the DE burn-in runs).
LAPLACE_TRIAL, LAPLACE_ACCEPTANCE = "trial of a proposal around the least-squares point", 0.4
#: The differential-evolution mixture: (move, weight).
DE_WEIGHTS = (("DEMove", 0.8), ("DESnookerMove", 0.2))


class VectorSampler(emcee.EnsembleSampler):
    """:class:`emcee.EnsembleSampler` for a vectorised log-probability that
    returns one float per walker and no blobs: ``compute_log_prob`` checks
    the coordinates and the result as emcee does (no inf or NaN coordinate,
    no NaN log-probability) without emcee's per-walker loop for blobs.

    ``moves`` is a list of (move, weight) or of moves (equal weights);
    ``label`` names the phase it runs in the sampler's record, and
    ``recorded`` holds the steps and per-walker
    acceptances already recorded (:class:`_Phases`)."""

    def __init__(self, nwalkers, ndim, log_prob_fn, moves, label=""):
        moves = [m if isinstance(m, tuple) else (m, 1.0) for m in moves]
        super().__init__(nwalkers, ndim, log_prob_fn, moves=moves, vectorize=True)
        self.move_list = [m for m, _ in moves]
        self.phase = {"label": label,
                      "moves": [{"move": _move_name(m), "weight": float(w)} for m, w in moves]}
        self.recorded = (0, np.zeros(nwalkers))

    def compute_log_prob(self, coords):
        if not np.all(np.isfinite(coords)):
            raise ValueError("At least one parameter value was infinite or NaN")
        log_prob = np.asarray(self.log_prob_fn(coords), dtype=float).reshape(len(coords))
        if np.any(np.isnan(log_prob)):
            raise ValueError("Probability function returned NaN")
        return log_prob, None


def integrated_time(x):
    """Integrated autocorrelation time per parameter of ``x`` (steps,
    walkers, ndim): :func:`emcee.autocorr.integrated_time` (c = 5), without
    its chain-length check (the convergence rule applies its own)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return emcee.autocorr.integrated_time(x, c=5, tol=0)


def split_rhat(chain, ess):
    """Split R-hat between the two halves of ``chain`` (n, W, ndim), each half
    flattened over walkers and counted as ``ess / 2`` effective draws: the
    potential scale reduction of Gelman et al. (BDA3, eqs. 11.3-11.4) for two
    sequences of ``n = ess / 2`` draws, ``sqrt(((n - 1) / n W + B / n) / W)``."""
    n = chain.shape[0] // 2
    a = chain[:n].reshape(-1, chain.shape[2])
    b = chain[n:2 * n].reshape(-1, chain.shape[2])
    m_eff = np.maximum(ess / 2.0, 2.0)
    w = 0.5 * (a.var(axis=0, ddof=1) + b.var(axis=0, ddof=1))
    between = m_eff * (a.mean(axis=0) - b.mean(axis=0)) ** 2 / 2.0
    var_plus = (m_eff - 1) / m_eff * w + between / m_eff
    return np.sqrt(var_plus / w)


@dataclass
class Chain:
    """Kept (post burn-in, thinned) samples and convergence figures."""

    samples: np.ndarray       # (N, ndim)
    log_prob: np.ndarray      # (N,)
    tau: np.ndarray           # (ndim,)
    ess: np.ndarray           # (ndim,)
    rhat: np.ndarray          # (ndim,)
    acceptance: float
    n_steps: int              # steps of the chain held (trace), burn-in included; a
    n_walkers: int            # trial that accepted too rarely is not in it, but in
    burn: int                 # sampler["phases"] and sampler["steps"]
    converged: bool
    trace: np.ndarray         # (steps, W, ndim), thinned for plots
    sampler: dict = field(default_factory=dict)   # what was run: see :func:`sample`

    def convergence(self):
        """Every parameter's convergence figures and the run's size: a
        :class:`~bayescal.result.convergence.Convergence`, a posterior's
        ``convergence``."""
        return Convergence(tau=self.tau, ess=self.ess, rhat=self.rhat, acceptance=self.acceptance,
                           n_steps=self.n_steps, n_walkers=self.n_walkers, burn=self.burn,
                           converged=self.converged)

    def summary(self):
        """The ``convergence`` entry of a result file: the slowest parameter's
        figures, the run's size and whether the rule held
        (:meth:`~bayescal.result.convergence.Convergence.summary`)."""
        return self.convergence().summary()


class _Phases:
    """emcee samplers run one after another on the same walkers: each starts
    from the last state of the one before and continues its random stream;
    :meth:`record` lists what each ran."""

    def __init__(self, log_prob, n_walkers, ndim, bar):
        self.log_prob, self.n_walkers, self.ndim, self.bar = log_prob, n_walkers, ndim, bar
        self.phases = []

    def new(self, moves, label):
        """An emcee sampler with ``moves``, a list of (move, weight)."""
        return VectorSampler(self.n_walkers, self.ndim, self.log_prob, moves, label)

    def run(self, sampler, state, n_steps):
        """Advance ``sampler`` ``n_steps`` from ``state``; returns the last state."""
        for move in sampler.move_list:
            if isinstance(move, IndependenceMove):
                move.plan(n_steps)
        for state in sampler.sample(state, iterations=n_steps, skip_initial_state_check=True):
            if self.bar.step is not None:
                self.bar.step()
        return state

    def close(self, sampler, label=None):
        """Record what ``sampler`` ran since it was last recorded: its moves,
        steps and mean acceptance."""
        done_steps, done_acc = sampler.recorded
        steps = sampler.iteration - done_steps
        accepted = sampler.backend.accepted - done_acc
        self.phases.append(dict(sampler.phase, label=label or sampler.phase["label"],
                                steps=int(steps),
                                acceptance=float(np.mean(accepted) / max(steps, 1))))
        self.bar.phase(self.phases[-1]["label"], int(steps), self.phases[-1]["acceptance"])
        sampler.recorded = (sampler.iteration, sampler.backend.accepted.copy())

    def record(self):
        return {"library": "emcee", "version": emcee.__version__,
                "walkers": int(self.n_walkers), "vectorize": True,
                "steps": int(sum(p["steps"] for p in self.phases)), "phases": self.phases}


def _move_name(move):
    if isinstance(move, IndependenceMove):
        return f"IndependenceMove (multivariate t proposal, nu={move.proposal.nu:g})"
    return type(move).__name__


def _de_moves():
    return [(emcee.moves.DEMove(), DE_WEIGHTS[0][1]), (emcee.moves.DESnookerMove(),
                                                       DE_WEIGHTS[1][1])]


def default_walkers(ndim):
    """The walkers :func:`sample` uses by default: ``max(32, 4 ndim)``, made even."""
    n = max(32, 4 * int(ndim))
    return n + n % 2


def sample(model, theta_start, cov, *, seed=0, n_walkers=None, min_ess=1000, n_tau=50,
           rhat_max=1.01, max_steps=None, progress=True, move="independence", what=None,
           laplace=False):
    """Sample ``model``'s posterior with emcee from around ``theta_start``
    until the convergence rule holds or ``max_steps`` steps are run.

    Parameters
    ----------
    model : object with ``ndim`` and a vectorised ``log_prob((k, ndim)) -> (k,)``.
    theta_start, cov : the walkers start from a Gaussian with covariance
        ``cov`` (the least-squares Laplace approximation) around ``theta_start``.
    seed : the chain is a function of the seed alone (same seed, same chain).
    n_walkers : default ``max(32, 4 ndim)``, made even.
    min_ess, n_tau, rhat_max : the convergence rule (module docstring).
    max_steps : steps of the kept phase's sampler after which the chain stops
        unconverged (a DE fallback's sampler counts its burn-in; at least one
        step runs); None: what :data:`bayescal.core.budget.SAMPLE_WORK`
        evaluations leave after the burn-in.
    progress : a bar toward the rule on a terminal, else lines (:mod:`.display`).
    what : what is sampled, named in every progress line ("element U"), or None.
    move, laplace : "independence" (the default: a DE burn-in, then
        :class:`IndependenceMove`; with ``laplace``, a trial of the t proposal
        around ``theta_start`` and ``cov`` first, the burn-in where it accepts
        enough) or "de" (emcee's DE moves throughout): module docstring.

    Returns
    -------
    Chain
        Kept samples; ``sampler`` records emcee's version, the walkers, each
        phase's moves, weights, steps and acceptance, and the log-probability
        evaluations made (``evaluations``, every walker start and every
        phase, a failed trial's included) and allowed (``evaluation_limit``).
        An unconverged chain also raises a :class:`NotConvergedWarning`.
    """
    if move not in ("de", "independence"):
        raise ValueError(f"unknown move {move!r}")
    n_walkers = (n_walkers or default_walkers(model.ndim)) + (n_walkers or 0) % 2
    log_prob = CountedLogProb(model.log_prob)
    rule = _Rule(min_ess=min_ess, n_tau=n_tau, rhat_max=rhat_max,
                 max_steps=None if max_steps is None else int(max_steps))
    p0 = _start_walkers(log_prob, theta_start, cov, np.random.default_rng(seed), n_walkers)
    bar = progress_display(progress, 1000, n_tau, min_ess, rhat_max, rule.max_steps, what)
    phases = _Phases(log_prob, n_walkers, model.ndim, bar)
    sampler = phases.new(_de_moves(), "kept chain, differential-evolution moves")
    state = emcee.State(p0, random_state=np.random.RandomState(seed).get_state())
    pre, sampler, state, pace = _burn_in(phases, sampler, state, rule,
                                         independence=move == "independence",
                                         laplace=(theta_start, cov) if laplace else None)
    rule, limit = _kept_limit(rule, log_prob.n, sampler.iteration, n_walkers)
    bar.limit(pre.shape[0] + rule.max_steps)     # a DE fallback's sampler holds its burn-in
    kept = _run_to_rule(phases, sampler, state, rule, pace, pre.shape[0])
    bar.close()
    phases.close(sampler)
    record = dict(phases.record(), max_steps=rule.max_steps, evaluations=log_prob.n,
                  evaluation_limit=limit)
    chain = _kept_chain(sampler, pre, kept, record)
    if not chain.converged:
        warnings.warn(not_converged_line(chain.summary(), option="max_steps"), NotConvergedWarning,
                      stacklevel=2)
    return chain


def _kept_chain(sampler, pre, kept, record):
    """The :class:`Chain` of ``sampler``'s kept phase, ``kept`` as
    :func:`_run_to_rule` returns it, ``pre`` the chain run before it and
    ``record`` what was run."""
    steps, burn, tau, ess, rhat, converged = kept
    offset, n_walkers = pre.shape[0], sampler.nwalkers
    thin = _thin(tau, (steps - burn) * n_walkers)
    full = np.concatenate([pre, sampler.get_chain()]) if offset else sampler.get_chain()
    return Chain(samples=sampler.get_chain(discard=burn, thin=thin, flat=True),
                 log_prob=sampler.get_log_prob(discard=burn, thin=thin).reshape(-1), tau=tau,
                 ess=ess, rhat=rhat, acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=offset + steps, n_walkers=n_walkers, burn=offset + burn,
                 converged=converged, trace=full[:: max(1, (offset + steps) // 1000)],
                 sampler=record)


def _thin(tau, n_kept):
    """The kept chain's thinning: a quarter of the smallest tau (1 for a very
    short chain, whose tau is not finite), and at least what keeps
    :data:`MAX_KEPT` of its ``n_kept`` draws."""
    thin = max(1, int(tau.min() / 4)) if np.all(np.isfinite(tau)) else 1
    return max(thin, -(-int(n_kept) // MAX_KEPT))


@dataclass(frozen=True)
class _Rule:
    """The convergence rule (module docstring) and the step budget."""
    min_ess: float
    n_tau: float
    rhat_max: float
    max_steps: int


class CountedLogProb:
    """A vectorised log-probability that counts the points it is evaluated
    at (``n``): the sampler's work, in :data:`bayescal.core.budget.UNIT`."""

    def __init__(self, log_prob):
        self.log_prob, self.n = log_prob, 0

    def __call__(self, x):
        self.n += len(x)
        return self.log_prob(x)


def _kept_limit(rule, used, start, n_walkers):
    """The kept phase's step limit and the sampler's whole work limit, from
    the evaluations ``used`` before the kept phase and the steps ``start``
    its sampler has already run (a DE fallback's burn-in): ``(rule,
    limit)``. Without a ``max_steps`` the kept phase gets what
    :data:`~bayescal.core.budget.SAMPLE_WORK` leaves after ``used``, in
    whole steps of ``n_walkers`` evaluations; it runs at least one step."""
    if rule.max_steps is None:
        rule = replace(rule, max_steps=start + max(1, (SAMPLE_WORK - used) // n_walkers))
    return rule, used + max(1, rule.max_steps - start) * n_walkers


def _start_walkers(log_prob, theta_start, cov, rng, n_walkers):
    """Walkers drawn from a Gaussian around ``theta_start``; those where
    ``log_prob`` is not finite drawn again, closer (up to 100 times)."""
    p0 = rng.multivariate_normal(theta_start, cov, size=n_walkers)
    for _ in range(100):
        bad = ~np.isfinite(log_prob(p0))
        if not bad.any():
            break
        p0[bad] = rng.multivariate_normal(theta_start, 0.01 * cov, size=int(bad.sum()))
    return p0


def _burn_in(phases, sampler, state, rule, independence, laplace=None):
    """The burn-in before the kept phase: ``(pre, sampler, state, pace)``,
    the chain run before the kept phase's sampler (none for the DE moves
    alone), that sampler, its start state and ``pace`` = (first chunk of
    steps, least burn-in, least chunk). ``laplace`` (mean, covariance): the
    t proposal around them is tried first; where it accepts less than
    :data:`LAPLACE_ACCEPTANCE` the DE burn-in runs from the walkers' start,
    as without it."""
    pre, pace = np.empty((0, phases.n_walkers, phases.ndim)), (1000, 100, 200)
    if not independence:
        return pre, sampler, state, pace
    frozen = None
    if laplace is not None:
        frozen = _trial(phases, lambda: TProposal(*laplace), state, LAPLACE_TRIAL,
                        LAPLACE_ACCEPTANCE)
    if frozen is None:
        state = phases.run(sampler, state, DE_BURN)
        frozen = _frozen_proposal(phases, sampler, state, DE_BURN // 2)
    if frozen is None:      # once more, from DE draws that have had longer to settle
        state = phases.run(sampler, state, DE_RETRY)
        frozen = _frozen_proposal(phases, sampler, state, DE_BURN + DE_RETRY // 2)
    if frozen is None:
        return pre, sampler, state, pace
    pre, sampler, state = frozen
    min_burn, min_chunk = 10, 50
    # the first run: what the rule needs at the adaptation's mixing
    # (its tau, at least 1), with a fifth to spare; then as below
    tau0 = max(1.0, float(np.max(integrated_time(pre[-ADAPT:]))))
    chunk = int(np.ceil(1.2 * (min_burn + max(rule.n_tau, rule.min_ess / phases.n_walkers)
                                * tau0)))
    return pre, sampler, state, (min(max(chunk, min_chunk), 150), min_burn, min_chunk)


def _run_to_rule(phases, sampler, state, rule, pace, offset):
    """Run ``sampler`` in chunks until ``rule`` holds or its ``max_steps``
    are run; returns ``(steps, burn, tau, ess, rhat, converged)`` of the
    kept phase (``offset``: the steps run before it, for the progress bar)."""
    chunk, min_burn, min_chunk = pace
    n_walkers, bar = phases.n_walkers, phases.bar
    steps, converged = sampler.iteration, False
    chunk = max(1, min(chunk, rule.max_steps - steps))
    while True:
        state = phases.run(sampler, state, chunk)
        steps += chunk
        full = sampler.get_chain()
        tau_all = integrated_time(full[steps // 2:])
        burn = int(min(steps // 2, max(min_burn, 5 * np.max(tau_all))))
        kept = full[burn:]
        tau = integrated_time(kept)
        ess = kept.shape[0] * n_walkers / tau
        rhat = split_rhat(kept, ess)
        need = max(rule.n_tau * tau.max() + burn, burn + (steps - burn) * rule.min_ess / ess.min())
        if (kept.shape[0] >= rule.n_tau * tau.max() and ess.min() >= rule.min_ess
                and rhat.max() < rule.rhat_max):
            converged = True
            bar.goal(offset + steps, kept.shape[0] / tau.max(), ess.min(), rhat.max(), tau.max(),
                     offset + steps)
            break
        chunk = int(min(max(min_chunk, 1.1 * need - steps), rule.max_steps - steps))
        bar.goal(offset + steps + chunk, kept.shape[0] / tau.max(), ess.min(), rhat.max(),
                 tau.max(), offset + steps)
        if steps >= rule.max_steps:
            break
    return steps, burn, tau, ess, rhat, converged


def _frozen_proposal(phases, de, state, discard):
    """One adaptation round of the t proposal after the DE burn-in, fitted to
    its draws after the first ``discard`` steps; returns (burn-in chain, the
    sampler with the frozen proposal, its start state), or None (the DE
    sampler carries on) when the proposal cannot be fitted or accepts too
    rarely."""
    phases.close(de, "burn-in, differential-evolution moves")
    frozen = _trial(phases, lambda: TProposal.fit(de.get_chain(discard=discard, flat=True)),
                    state, "trial of the proposal fitted to the burn-in", MIN_ACCEPTANCE)
    if frozen is None:
        return None
    return (np.concatenate([de.get_chain(), frozen[0]]),) + frozen[1:]


def _trial(phases, proposal, state, label, least):
    """:data:`ADAPT` steps of :class:`IndependenceMove` from ``state`` with
    the :class:`TProposal` that ``proposal()`` makes: ``(the trial's chain,
    a sampler with the proposal refitted to its draws, its last state)``, or
    None when a proposal cannot be made (a degenerate spread) or the trial
    accepts less than ``least`` of its proposals."""
    try:
        adapt = phases.new([(IndependenceMove(proposal()), 1.0)], label)
        last = phases.run(adapt, state, ADAPT)
        if np.mean(adapt.acceptance_fraction) < least:
            phases.close(adapt, f"{label}, accepted too rarely")
            return None
        phases.close(adapt)
        final = phases.new([(IndependenceMove(TProposal.fit(adapt.get_chain(flat=True))), 1.0)],
                           "kept chain, proposal fitted to the trial")
    except np.linalg.LinAlgError:   # a degenerate spread: no proposal
        return None
    return adapt.get_chain(), final, last
