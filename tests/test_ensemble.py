"""bayescal's light sampler loop is emcee's algorithm number for number, and
the spectra's window and detrend are scipy's, so dropping the two imports
(start-up, issue 16) changes no result."""
from __future__ import annotations

import numpy as np
import pytest

from bayescal.core.ensemble import Ensemble, integrated_time

emcee = pytest.importorskip("emcee")

COV = np.array([[1.0, 0.6, 0.0, 0.1], [0.6, 2.0, 0.3, 0.0], [0.0, 0.3, 0.5, 0.0],
                [0.1, 0.0, 0.0, 3.0]])
PREC = np.linalg.inv(COV)


def log_prob(q):
    q = np.atleast_2d(q)
    return -0.5 * np.einsum("ij,jk,ik->i", q, PREC, q)


def _emcee_chain(p0, seed, steps):
    s = emcee.EnsembleSampler(p0.shape[0], p0.shape[1], log_prob, vectorize=True,
                              moves=[(emcee.moves.DEMove(), 0.8),
                                     (emcee.moves.DESnookerMove(), 0.2)])
    s.random_state = np.random.RandomState(seed).get_state()
    state = s.run_mcmc(p0, steps // 2)        # two chunks, as bayescal's sampler runs
    s.run_mcmc(state, steps - steps // 2)
    return s


@pytest.mark.parametrize("seed", [0, 7])
def test_same_chain_as_emcee(seed):
    p0 = np.random.default_rng(seed).standard_normal((16, 4))
    ref = _emcee_chain(p0, seed, 400)
    ens = Ensemble(log_prob, p0, np.random.RandomState(seed).get_state())
    ens.run(200)
    ens.run(200)
    np.testing.assert_array_equal(ens.get_chain(), ref.get_chain())
    np.testing.assert_array_equal(ens.get_chain(log_prob=True), ref.get_log_prob())
    np.testing.assert_array_equal(ens.get_chain(discard=37, thin=3, flat=True),
                                  ref.get_chain(discard=37, thin=3, flat=True))
    np.testing.assert_array_equal(ens.acceptance_fraction, ref.acceptance_fraction)
    assert 0.1 < np.mean(ens.acceptance_fraction) < 0.9      # the moves do move
    tau = integrated_time(ens.get_chain()[100:])
    np.testing.assert_array_equal(tau, emcee.autocorr.integrated_time(ref.get_chain()[100:],
                                                                      tol=0))
    # and the chain samples the target: variances within 15 % of the truth
    flat = ens.get_chain(discard=100, flat=True)
    np.testing.assert_allclose(flat.var(axis=0), np.diag(COV), rtol=0.15)


def test_window_and_detrend_are_scipys():
    from scipy.signal import detrend as sp_detrend
    from scipy.signal.windows import hann as sp_hann

    from bayescal.core.spectra import detrend, hann

    for m in (16, 1000, 8192):
        np.testing.assert_array_equal(hann(m), sp_hann(m, sym=False))
    x = np.random.default_rng(1).standard_normal((5, 3, 700)).cumsum(axis=-1)
    np.testing.assert_array_equal(detrend(x), sp_detrend(x, axis=-1, type="linear"))
    np.testing.assert_array_equal(detrend(x[0], axis=1), sp_detrend(x[0], axis=1, type="linear"))
