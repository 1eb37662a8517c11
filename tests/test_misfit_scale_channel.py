"""The noise scale per SUT channel (bayescal.core.model.channel_scale): each
channel's share of a band's whitened residual energy, from the symmetric
square root of the precision, and the misfit scale applied to each channel's
shares. The closed form against numerical integration over the channels'
scales of the Gaussian whose covariance they scale (``V^(1/2) D V^(1/2)``,
channels correlated); the pooling across bands by simulation-based
calibration: scales drawn from their prior, residuals from the model, each
channel's posterior of its pooled scale holds the truth at its rate; and on
fitted models (base and errors in variables) the shares against the model's
own band energies and likelihood."""
import numpy as np
from scipy.integrate import simpson
from scipy.stats import binom, gamma

from bayescal.core.model import misfit_scale
from bayescal.core.model.channel_scale import (channel_energy, channel_loglik, channel_scale,
                                               complex_channel_energy, real_channel_energy,
                                               sym_sqrt)
from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair

A = 2.0


def _covariance(rng, n):
    """A random covariance with every pair of entries correlated."""
    m = rng.normal(size=(n, n))
    return m @ m.T + 0.5 * np.eye(n)


def test_shares_sum_and_their_degrees_of_freedom():
    """The shares add to the band's energy ``x^T W x / 2``; their degrees of
    freedom to half the precision's rank; a precision without terms between
    channels gives each channel its own ``x_c^T W_cc x_c / 2``."""
    rng = np.random.default_rng(3)
    w = np.stack([np.linalg.inv(_covariance(rng, 8)) for _ in range(3)])
    x = rng.normal(size=(5, 3, 8))
    q, k = real_channel_energy(x, w, 2)
    assert np.allclose(q.sum(axis=-1), 0.5 * np.einsum("nbi,bij,nbj->nb", x, w, x))
    assert np.allclose(k, 2.0)
    # block diagonal by channel: entries (0, 1, 4, 5) are channel 0's
    c0, c1 = [0, 1, 4, 5], [2, 3, 6, 7]
    wb = np.zeros_like(w)
    for idx in (c0, c1):
        wb[:, np.ix_(idx, idx)[0], np.ix_(idx, idx)[1]] = w[:, np.ix_(idx, idx)[0],
                                                             np.ix_(idx, idx)[1]]
    qb, _ = real_channel_energy(x, wb, 2)
    for c, idx in enumerate((c0, c1)):
        xi = x[..., idx]
        wi = wb[:, np.ix_(idx, idx)[0], np.ix_(idx, idx)[1]]
        assert np.allclose(qb[..., c], 0.5 * np.einsum("nbi,bij,nbj->nb", xi, wi, xi))


def test_scale_per_channel_is_the_marginal_of_the_scaled_gaussian():
    """With the covariance ``V^(1/2) D V^(1/2)`` (``D`` channel c's scale on
    its entries, each scale inverse-gamma(a, a)), the likelihood integrated
    over both channels' scales differs from :func:`channel_loglik` of the
    shares by a constant: the same for any statistic ``x``."""
    rng = np.random.default_rng(11)
    v = _covariance(rng, 8)
    root = sym_sqrt(v)[0]
    owner = np.array([0, 0, 1, 1, 0, 0, 1, 1])
    u = np.linspace(-7.0, 7.0, 401)                 # log s on a grid, both channels
    s1, s2 = np.meshgrid(np.exp(u), np.exp(u), indexing="ij")
    log_prior = (gamma.logpdf(1 / s1, A, scale=1 / A) - 2 * np.log(s1)
                 + gamma.logpdf(1 / s2, A, scale=1 / A) - 2 * np.log(s2) + u[:, None] + u[None])
    d = np.where(owner == 0, s1.ravel()[:, None], s2.ravel()[:, None])      # (G, 8)
    covs = (root[None] * d[:, None, :]) @ root                              # (G, 8, 8)
    _, logdet = np.linalg.slogdet(covs)
    diffs = []
    for scale in (0.5, 1.0, 4.0):
        x = rng.normal(size=8) * scale
        solved = np.linalg.solve(covs, np.broadcast_to(x, d.shape)[..., None])[..., 0]
        quad = solved @ x
        logs = -0.5 * (8 * np.log(2 * np.pi) + logdet + quad).reshape(s1.shape) + log_prior
        top = logs.max()
        numeric = np.log(simpson(simpson(np.exp(logs - top), x=u), x=u)) + top
        q, k = real_channel_energy(x[None, None], np.linalg.inv(v)[None], 2)
        diffs.append(numeric - channel_loglik(q, k, A)[0])
    assert np.ptp(diffs) < 1e-4


def _simulated_bands(rng, n_bands, n_r, sigma, s_true):
    """Residuals of one pair, (1, 1, B, 2, n_r): rows with covariance
    ``Sigma^(1/2) diag(s) Sigma^(1/2)`` in every band, columns with the
    reference's ``S_rr``; and the precisions ``A = Sigma^-1``, ``B = S_rr^-1``."""
    srr = np.stack([_covariance(rng, n_r) for _ in range(n_bands)])
    root = sym_sqrt(sigma)[0]
    mix = root * np.sqrt(s_true)
    z = (rng.normal(size=(n_bands, 2, n_r)) + 1j * rng.normal(size=(n_bands, 2, n_r))) / np.sqrt(2)
    r = mix @ z @ np.linalg.cholesky(srr).conj().transpose(0, 2, 1)
    a = np.broadcast_to(np.linalg.inv(sigma), (n_bands, 2, 2))
    return r[None, None], a, np.linalg.inv(srr)[None]


def test_pooled_scale_per_channel_holds_its_truth():
    """Simulation-based calibration of the pooled scale per channel (no own
    scales, free): 300 pairs of 12 bands, two correlated SUT channels (row
    correlation 0.6) and two reference channels; each channel's scale drawn
    from inverse-gamma(a, a). Each channel's posterior of ``1 / s_c`` is
    Gamma(a + K_c, a + Q_c) from its shares, so the truth falls inside its
    central 90 % at the binomial rate (99 % band); the variance factor is
    ``(a + Q_c) / (a + K_c)``."""
    rng = np.random.default_rng(20240611)
    sigma = np.array([[1.0, 0.6], [0.6, 1.0]]) * 2.5
    n, inside = 300, 0
    for _ in range(n):
        s_true = 1.0 / rng.gamma(A, 1.0 / A, size=2)
        r, a, b = _simulated_bands(rng, 12, 2, sigma, s_true)
        q, k = complex_channel_energy(r, a, b)
        big_q, big_k = q[0].sum(axis=0), k.sum(axis=0)
        p = gamma.cdf(1.0 / s_true, A + big_k, scale=1.0 / (A + big_q))
        inside += int(np.sum((p > 0.05) & (p < 0.95)))
        factor = channel_scale(q[0], k, A, pi=0.0)
        assert np.allclose(factor, ((A + big_q) / (A + big_k))[None])
    lo, hi = binom.ppf([0.005, 0.995], 2 * n, 0.9)
    assert lo <= inside <= hi, (inside, lo, hi)


def test_fitted_models_split_their_band_energy(monkeypatch):
    """On a simulated 3+3 pair, for the base model (reference quiet) and the
    errors-in-variables one (its noise estimated): each channel's shares of
    a fit's draws sum to the model's band energies and their degrees of
    freedom to the band's; with ``PER_CHANNEL`` on, the model's likelihood
    is the sum over channels of the shares' marginal."""
    sim = simulate_pair(duration=900.0, fs=5.0, seed=5, coherence=0.95)
    for ref_noise in ("quiet", "estimate"):
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                         ref_xml=sim.ref_inventory, band=(0.05, 1.0), seed=1, progress=False,
                         diagnose=False, ref_noise=ref_noise)
        model = post.state.model
        theta = post.samples[::max(1, len(post.samples) // 40)]
        q, k = model.band_energy(theta)
        qc, kc = channel_energy(model, theta)
        assert qc.shape == q.shape + (3,)
        assert np.allclose(qc.sum(axis=-1), q, rtol=1e-9)
        assert np.allclose(kc.sum(axis=-1), k)
        assert np.all(qc >= 0)
        with monkeypatch.context() as m:
            m.setattr(misfit_scale, "PER_CHANNEL", True)
            got = model.log_likelihood(theta)
        want = channel_loglik(qc, kc, model.misfit_shape, model.noise.weight)
        assert np.allclose(got, want)
        assert not np.allclose(got, model.log_likelihood(theta))
