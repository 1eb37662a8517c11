"""The independence move of every posterior's kept chain: a multivariate
Student t proposal (:class:`TProposal`) and :class:`IndependenceMove`, an
:class:`emcee.moves.Move` that proposes its draws whatever the walkers'
positions, so that a run of steps is drawn and evaluated in a few batched
calls (:mod:`.mcmc` drives it).
"""
from __future__ import annotations

import emcee
import numpy as np

#: Points per log-probability call of :class:`IndependenceMove`'s batches
#: (a 9-parameter errors-in-variables pair model costs about 31 us a point
#: in calls of 256-512 points, 37-55 us in calls of 2048, whose arrays leave
#: the cache; docs/validation/speed.md, "Whole commands").
BATCH = 512
#: Degrees of freedom of the t proposal (tau about 1.6 at d = 9, 2.3 at d = 15
#: for a Gaussian target with the covariance fitted from 3600 draws).
NU = 10.0


class TProposal:
    """Multivariate Student t with location ``mean``, scale matrix ``cov`` and
    ``nu`` degrees of freedom: heavier tails than a near-Gaussian posterior,
    so the ratio target / proposal stays bounded."""

    def __init__(self, mean, cov, nu=NU):
        self.mean = np.asarray(mean, float)
        self.nu = float(nu)
        self.chol = np.linalg.cholesky(np.atleast_2d(cov))
        self.ndim = self.mean.size

    @classmethod
    def fit(cls, draws, nu=NU):
        """Mean and covariance of ``draws`` (n, ndim)."""
        draws = np.asarray(draws, float)
        return cls(draws.mean(axis=0), np.atleast_2d(np.cov(draws, rowvar=False)), nu)

    def draw(self, random, n):
        """``n`` draws, from a ``numpy.random.RandomState`` (emcee's)."""
        z = random.standard_normal((n, self.ndim)) @ self.chol.T
        w = np.sqrt(random.chisquare(self.nu, size=(n, 1)) / self.nu)
        return self.mean + z / w

    def log_pdf(self, x):
        """Log density up to a constant (it cancels in the acceptance ratio)."""
        y = np.linalg.solve(self.chol, (np.atleast_2d(x) - self.mean).T)
        return -0.5 * (self.nu + self.ndim) * np.log1p(np.sum(y * y, axis=0) / self.nu)


class IndependenceMove(emcee.moves.Move):
    """Independence Metropolis-Hastings as an emcee move: every walker
    proposes a fresh draw ``q`` of a fixed :class:`TProposal` ``g``, whatever
    its position ``x``, accepted with probability
    ``min(1, pi(q) g(x) / (pi(x) g(q)))``, which leaves the posterior ``pi``
    invariant. Each walker is its own Markov chain.

    Proposals do not depend on the walkers' positions, so the proposals of a
    run of steps announced by :meth:`plan` are drawn, and their
    log-probabilities computed through emcee's ``compute_log_prob_fn``, in a
    few calls of up to :data:`BATCH` points; each ``propose`` (one emcee
    step) then takes its step's proposals and decides acceptance, as
    :class:`emcee.moves.MHMove` would."""

    def __init__(self, proposal):
        self.proposal = proposal
        self._planned = 1
        self._queue = []         # [(q, log pi(q), log g(q)) per step]
        self._lg = None          # log g at the walkers' current positions

    def plan(self, n_steps):
        """The next run of emcee steps is ``n_steps`` long: draw and evaluate
        that many steps of proposals at once (proposals left over are dropped)."""
        self._planned, self._queue = max(1, int(n_steps)), []

    def _refill(self, model, n_walkers):
        n = self._planned * n_walkers
        q = self.proposal.draw(model.random, n)
        lp = np.concatenate([model.compute_log_prob_fn(q[i:i + BATCH])[0]
                             for i in range(0, n, BATCH)])
        lg = self.proposal.log_pdf(q)
        shape = (self._planned, n_walkers)
        self._queue = list(zip(q.reshape(shape + (-1,)), lp.reshape(shape), lg.reshape(shape)))
        self._queue.reverse()
        self._planned = 1

    def propose(self, model, state):
        """One step: returns the new state and which walkers accepted."""
        n_walkers = state.coords.shape[0]
        if not self._queue:
            self._refill(model, n_walkers)
        q, lp_q, lg_q = self._queue.pop()
        if self._lg is None or self._lg.shape[0] != n_walkers:
            self._lg = self.proposal.log_pdf(state.coords)
        accepted = np.log(model.random.rand(n_walkers)) < lp_q - state.log_prob + self._lg - lg_q
        state = self.update(state, emcee.State(q, log_prob=lp_q), accepted)
        self._lg = np.where(accepted, lg_q, self._lg)
        return state, accepted
