"""emcee's ensemble sampler, reduced to the moves bayescal uses, in one light loop.

:class:`Ensemble` runs emcee's algorithm (Foreman-Mackey et al. 2013): at each
step one move is drawn from the mixture (``emcee.moves.DEMove`` with weight
0.8, ``emcee.moves.DESnookerMove`` with weight 0.2), the walkers are split at
random into sub-ensembles (2 for DE, 4 for snooker) and each is updated
against the others, one vectorised log-probability call per sub-ensemble.
It draws from a ``numpy.random.RandomState`` in exactly emcee's order, so for
the same seed and start it produces emcee 3.1's chain number for number
(``tests/test_ensemble.py`` runs both side by side). :func:`integrated_time`
is ``emcee.autocorr.integrated_time`` (Sokal's automatic window, c = 5).

Why not import emcee itself: ``import emcee`` imports every move, and its KDE
move imports ``scipy.stats`` (about 1-2 s of start-up, more than the whole
sampling of an orientation fit); and emcee's per-walker Python around each
log-probability call (State objects, a backend, an acceptance loop and,
for the snooker move, a proposal loop) cost about as much as the
log-probability itself. Here acceptance is one vectorised comparison; only
the snooker move (a fifth of the steps) keeps emcee's per-walker loop, whose
draw order and arithmetic a vectorised form would not reproduce to the last
bit.
"""
from __future__ import annotations

import numpy as np

#: (name, weight, number of sub-ensembles) of the move mixture.
MOVES = (("de", 0.8, 2), ("snooker", 0.2, 4))
#: DE-snooker stretch (emcee's default) and DE gamma scatter.
SNOOKER_GAMMA = 1.7
DE_SIGMA = 1.0e-5


def _nondiagonal_pairs(n):
    """emcee.moves.de._get_nondiagonal_pairs: ordered pairs (i, j), i != j."""
    rows, cols = np.tril_indices(n, -1)
    return np.column_stack([np.concatenate([rows, cols]), np.concatenate([cols, rows])])


class StoredChain:
    """The stored chain of a set of walkers: ``_store`` appends a run, and
    ``get_chain``/``acceptance_fraction`` read it as emcee does. Subclasses
    set ``coords`` (W, ndim), ``log_prob`` (W,) and call ``_init_chain``."""

    def _init_chain(self):
        self.chain = np.empty((0, self.n_walkers, self.ndim))
        self.chain_log_prob = np.empty((0, self.n_walkers))
        self.accepted = np.zeros(self.n_walkers)
        self.iteration = 0

    def _store(self, chain, lps):
        self.chain = np.concatenate([self.chain, chain])
        self.chain_log_prob = np.concatenate([self.chain_log_prob, lps])
        self.iteration += chain.shape[0]

    def get_chain(self, discard=0, thin=1, flat=False, log_prob=False):
        """As emcee's ``get_chain``/``get_log_prob``: steps ``discard + thin - 1``,
        every ``thin``; ``flat`` merges steps and walkers."""
        v = (self.chain_log_prob if log_prob else self.chain)[discard + thin - 1::thin]
        return v.reshape((-1,) + v.shape[2:]) if flat else v

    @property
    def acceptance_fraction(self):
        return self.accepted / max(self.iteration, 1)


class Ensemble(StoredChain):
    """Walkers, their log-probabilities and the stored chain.

    Parameters
    ----------
    log_prob : vectorised function ``(k, ndim) -> (k,)``.
    p0 : (W, ndim) start.
    random_state : ``numpy.random.RandomState`` state tuple (as
        ``sampler.random_state = ...`` in emcee).
    """

    def __init__(self, log_prob, p0, random_state):
        self.log_prob_fn = log_prob
        self.coords = np.array(p0, dtype=float)
        self.n_walkers, self.ndim = self.coords.shape
        if self.n_walkers < 2 * self.ndim:
            raise ValueError("red-blue moves need at least twice as many walkers as dimensions")
        self.random = np.random.RandomState()
        self.random.set_state(random_state)
        self.log_prob = self._evaluate(self.coords)
        self.weights = np.array([w for _, w, _ in MOVES])
        self.weights /= self.weights.sum()
        self.g0 = 2.38 / np.sqrt(2 * self.ndim)
        self._init_chain()
        self._pairs = {}

    def _evaluate(self, q):
        lp = np.asarray(self.log_prob_fn(q), dtype=float)
        if np.any(np.isnan(lp)):
            raise ValueError("Probability function returned NaN")
        return lp

    def _de(self, s, c):
        nc = c.shape[0]
        if nc not in self._pairs:
            self._pairs[nc] = _nondiagonal_pairs(nc)
        pairs = self._pairs[nc]
        ns = s.shape[0]
        pairs = pairs[self.random.choice(pairs.shape[0], size=ns, replace=True)]
        diffs = np.diff(c[pairs], axis=1).squeeze(axis=1)
        gamma = self.g0 * (1 + DE_SIGMA * self.random.randn(ns, 1))
        return s + gamma * diffs, np.zeros(ns)

    def _snooker(self, s, c):
        ns, ndim = s.shape
        nc = [len(x) for x in c]
        q = np.empty_like(s)
        metropolis = np.empty(ns)
        for i in range(ns):       # emcee's draw order and arithmetic (same last bits)
            w = np.array([c[j][self.random.randint(nc[j])] for j in range(3)])
            self.random.shuffle(w)
            z, z1, z2 = w
            delta = s[i] - z
            norm = np.linalg.norm(delta)
            u = delta / np.sqrt(norm)
            q[i] = s[i] + u * SNOOKER_GAMMA * (np.dot(u, z1) - np.dot(u, z2))
            metropolis[i] = np.log(np.linalg.norm(q[i] - z)) - np.log(norm)
        return q, 0.5 * (ndim - 1.0) * metropolis

    def step(self):
        """One step of the move mixture (emcee's RedBlueMove.propose)."""
        k = self.random.choice(len(MOVES), p=self.weights)
        name, _, nsplits = MOVES[k]
        inds = np.arange(self.n_walkers) % nsplits
        self.random.shuffle(inds)
        accepted = np.zeros(self.n_walkers, dtype=bool)
        for split in range(nsplits):
            s1 = inds == split
            sets = [self.coords[inds == j] for j in range(nsplits)]
            s, c = sets[split], sets[:split] + sets[split + 1:]
            q, factors = self._de(s, np.concatenate(c)) if name == "de" else self._snooker(s, c)
            new_lp = self._evaluate(q)
            ok = factors + new_lp - self.log_prob[s1] > np.log(self.random.rand(s.shape[0]))
            accepted[s1] = ok
            m1 = s1 & accepted
            self.coords[m1] = q[ok]
            self.log_prob[m1] = new_lp[ok]
        self.accepted += accepted

    def run(self, n_steps, on_step=None):
        """Advance ``n_steps`` steps, storing every one; ``on_step()`` (if
        given) is called after each, e.g. to move a progress bar."""
        chain = np.empty((n_steps, self.n_walkers, self.ndim))
        lps = np.empty((n_steps, self.n_walkers))
        for t in range(n_steps):
            self.step()
            chain[t], lps[t] = self.coords, self.log_prob
            if on_step is not None:
                on_step()
        self._store(chain, lps)


def _next_pow_two(n):
    i = 1
    while i < n:
        i <<= 1
    return i


def integrated_time(x, c=5):
    """Integrated autocorrelation time per parameter of ``x`` (steps, walkers,
    ndim), averaged over walkers: ``emcee.autocorr.integrated_time(x, c, tol=0)``
    with the same one-dimensional FFTs (a batched inverse FFT differs in the
    last bit)."""
    n_t, n_w, n_d = x.shape
    n = 2 * _next_pow_two(n_t)
    out = np.empty(n_d)
    for d in range(n_d):
        mean = np.zeros(n_t)
        for k in range(n_w):
            y = x[:, k, d]
            f = np.fft.fft(y - np.mean(y), n=n)
            acf = np.fft.ifft(f * np.conjugate(f))[:n_t].real
            mean += acf / acf[0]
        mean /= n_w
        taus = 2.0 * np.cumsum(mean) - 1.0
        m = np.arange(n_t) < c * taus
        out[d] = taus[int(np.argmin(m)) if np.any(m) else n_t - 1]
    return out
