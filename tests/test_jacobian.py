"""The batched forward-difference Jacobian (:mod:`bayescal.core.model.jacobian`)
agrees with scipy's ``2-point`` on a per-time-block model with an effect (a
diagnose search's), with either whitening product."""
from __future__ import annotations

import numpy as np
from scipy.optimize._numdiff import approx_derivative

from bayescal.core.model.jacobian import forward_jacobian
from bayescal.core.model.likelihood import Model


def test_batched_jacobian_matches_scipy(sim_pair):
    import bayescal
    from bayescal.criticism.effects import ClockDrift

    post = bayescal.calibrate(sut=sim_pair.sut, sut_xml=sim_pair.sut_inventory, ref=sim_pair.ref,
                              ref_xml=sim_pair.ref_inventory, band=(0.05, 1.0), progress=False,
                              min_ess=200, n_tau=20)
    m0 = post.state.model
    drift = ClockDrift(range(m0.spectra.n_u), m0.spectra)
    m = Model(m0.spectra, m0.ref_vectors, m0.blocks, m0.priors, effects=[drift], per_block=True)
    theta = np.r_[post.state.theta_ls, 0.01, 5.0]                 # 10 ms, 5 ppm
    m.estimate_noise(theta)
    fac = m.noise.cholesky()
    ref = approx_derivative(m.whitened_residual, theta, method="2-point", args=(fac,))
    scale = np.abs(ref).max()
    for matmul in (False, True):
        jac = forward_jacobian(m, matmul=matmul)(theta, fac)
        assert jac.shape == ref.shape
        np.testing.assert_allclose(jac, ref, rtol=0, atol=1e-6 * scale)


def test_band_fold_is_the_einsum():
    from bayescal.core.spectra.bandfold import fold

    rng = np.random.default_rng(3)
    f, q, b, g = 40, 7, 4, 5
    interp = rng.random((f, q))
    band_of = np.sort(rng.integers(0, b, f))
    band_of[band_of == 2] = 1                        # an empty band
    c = (rng.standard_normal((g, f, 3, 2)) + 1j * rng.standard_normal((g, f, 3, 2))).astype(
        np.complex64)
    want = np.einsum("fq,fb,gfij->giqbj", interp, np.eye(b)[band_of], c).reshape(g, 3, q, -1)
    np.testing.assert_allclose(fold(interp, band_of, b, c), want, rtol=1e-12, atol=1e-12)


def test_batched_jacobian_errors_in_variables(sim_pair):
    """The errors-in-variables model's statistic (noise coefficients profiled
    per point) differentiated in one call agrees with scipy's ``2-point``."""
    import bayescal
    from bayescal.core.model.eiv import EIVModel

    post = bayescal.calibrate(sut=sim_pair.sut, sut_xml=sim_pair.sut_inventory, ref=sim_pair.ref,
                              ref_xml=sim_pair.ref_inventory, band=(0.05, 1.0), progress=False,
                              min_ess=200, n_tau=20, ref_noise="estimate")
    m = post.state.model
    assert isinstance(m, EIVModel)
    fac = m.noise.cholesky()
    ref = approx_derivative(m.whitened_residual, post.state.theta_ls, method="2-point", args=(fac,))
    jac = forward_jacobian(m)(post.state.theta_ls, fac)
    assert jac.shape == ref.shape
    np.testing.assert_allclose(jac, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
