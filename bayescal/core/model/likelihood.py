"""The Frobenius residual of the orientation design document inside a likelihood with a noise model
estimated from the spectra.

Residual
--------
With ``Y_u = H_u^-1(a) X_u``, ``Y_r = H_r^-1 X_r`` (ground velocity) and
``T = V_u V_r^+`` the seed's relation is ``Y_u = T Y_r`` (noise aside). The
seed multiplies it on the right by ``X_u^H`` and sums over frequency:
``S_uu(a) - T S_ru``. That form carries the SUT's own noise power on its
diagonal and biases the fit as the coherence falls (gain too high by about
``1 / coherence``). bayescal uses the same Frobenius residual with the
reference as the right-hand factor, per band b:

    R_b(theta) = S_ur,b(a) - T(phi) S_rr,b,
    S_ur,b(a) = sum_{f in b} Y_u(f; a) Y_r(f)^H,   S_rr,b = sum_{f in b} Y_r Y_r^H,

which has zero mean at the truth whatever the SUT's noise (the SUT noise is
incoherent with the reference), so the estimate stays unbiased at low
coherence (``tests/test_likelihood.py`` measures both forms at coherence
0.9). One band is exactly the single sum. The reference's own noise is left
out here (``--ref-noise quiet``); :mod:`.eiv` models it.

Noise model
-----------
If the per-bin residual ``e = Y_u - T Y_r`` has covariance ``Sigma_b`` within
band b, ``vec(R_b)`` has covariance ``Sigma_b (x) S_rr,b^T`` and

    log L = - sum_b  tr( Sigma_b^-1 R_b S_rr,b^-1 R_b^H ) / c_b.

``Sigma_b`` is estimated from the band spectra at the least-squares point.
Window leakage between neighbouring bins, segment overlap and non-stationary
noise make the true scatter larger than the independent-bin formula says; the
factor ``c_b`` measures that ratio from the scatter of the per-segment band
residuals (with the lag-one covariance of overlapping segments), shrunk
toward its pooled value over bands. The noise model is held fixed while
sampling (a plug-in estimate, in the SUT's counts: :mod:`.noisescale`).

Time blocks
-----------
With ``per_block=True`` (forced by a time-dependent effect such as a
drifting clock) the residual is formed per band *and* per time block g of
the record, ``R_b,g = S_ur,b,g(a) - T S_rr,b,g``, with covariance
``Sigma_b (x) S_rr,b,g^T``. Summed over blocks, a phase that changes
linearly through the record cancels to first order (it only decoheres the
sum, evenly in its rate); per block its progression, sign included, is seen.

A model with effects measures ``c_b`` on the exact residuals of the time
blocks less their common part (per-segment band residuals apply the response
ratio at the band centre and miss a factor turning within a band, a delay's
phase); under ``MIN_TIME_BLOCKS`` blocks it falls back to the per-segment
estimate, which overstates ``c_b`` under a large delay.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import channel_scale, misfit_scale, noisescale, plugin
from ..budget import charge
from ..response import pendulum
from ..spectra.bandfold import fold
from ..spectra.dof import band_dof
from .channel import ChannelBlock  # noqa: F401  (re-exported: a Model is built of them)
from .effect import Effect  # noqa: F401  (the extension hook, re-exported)
from .inflation import lag_one_scatter, overlapping_segments, shrunk_inflation
from .nodes import NODES_PER_DECADE, interpolation_nodes
from ..response.family import gain_prior_factor
from ..priors import Priors

#: Fewest time blocks with which the per-block likelihood is used.
MIN_TIME_BLOCKS = 4


@dataclass
class NoiseModel:
    """Per-band precision factors: ``A_b = Sigma_b^-1 / c_b``, ``B_b = S_rr,b^-1``
    (per time block ``g`` with the per-block likelihood: ``S_rr,b,g^-1``)."""

    A: np.ndarray        # (B, n_u, n_u)
    B: np.ndarray        # (G, B, n_r, n_r), G = 1 unless per-block
    sigma: np.ndarray    # (B, n_u, n_u) per-bin residual covariance
    inflation: np.ndarray  # (B,) c_b
    scale0: np.ndarray | None = None   # (n_u, B) |H_nom / H(a)| per band at the plug-in point
    weight: np.ndarray | None = None   # (B,) band weights for the plug-in's own error (core.model.plugin)

    def cholesky(self):
        """Factors for the whitened residual ``L_A^H R L_B`` (each band's
        weight folded into ``L_A``: its squared norm is the weighted
        Gaussian ``-log L``)."""
        la = np.linalg.cholesky(self.A)
        if self.weight is not None:
            la = la * np.sqrt(self.weight)[:, None, None]
        return la, np.linalg.cholesky(self.B)


class Model:
    """Parameter layout, priors and the (vectorised) residual of one fit.

    Parameters
    ----------
    spectra : :class:`bayescal.core.spectra.welch.CrossSpectra`
    ref_vectors : (n_r, 3) reference channel axes (NED unit vectors).
    blocks : one :class:`ChannelBlock` per SUT channel, in spectra order.
    """

    def __init__(self, spectra, ref_vectors, blocks, priors=Priors(), effects=(), per_block=False):
        self.spectra = spectra
        self.blocks = list(blocks)
        self.priors = priors
        self.effects = list(effects)
        if len(self.blocks) != spectra.n_u:
            raise ValueError("one ChannelBlock per SUT channel is needed")
        self.ref_vectors = np.asarray(ref_vectors, float)
        self.ref_pinv = np.linalg.pinv(self.ref_vectors)          # (3, n_r)
        self._lay_out_parameters()
        self._fold_spectra(spectra)
        self._inverse = {k: b.family.inverse_ratio_at(self.nodes)
                         for k, b in enumerate(self.blocks) if b.free == "all"}
        self._blocked = [(e, sl) for e, sl in zip(self.effects, self.effect_slices) if e.blocked]
        self._fold_time_blocks(spectra, per_block)
        affected = {k for e in self.effects for k in e.rows}
        self._free_rows = [k for k, b in enumerate(self.blocks) if b.free != "none" or k in affected]
        # a gain alone scales its row of S_ur,b: no product over the nodes needed
        self._scaled_rows = [k for k in self._free_rows
                             if self.blocks[k].free == "gain" and k not in affected]
        self.noise = None

    def _lay_out_parameters(self):
        """Names and slices of theta: the channel blocks, then the effects."""
        self.names = [n for b in self.blocks for n in b.param_names()]
        self.slices, i = [], 0
        for b in self.blocks:
            self.slices.append((slice(i, i + b.manifold.n_params),
                                slice(i + b.manifold.n_params, i + b.n_params)))
            i += b.n_params
        # extension parameters (see Effect) follow the channel blocks
        self.effect_slices = []
        for e in self.effects:
            self.effect_slices.append(slice(i, i + e.n_params))
            self.names += [f"{e.name}:{p}" for p in e.param_names]
            i += e.n_params
        self.ndim = len(self.names)

    def _fold_spectra(self, spectra):
        """Band sums of the spectra and the SUT rows folded with the
        interpolation weights."""
        nu = spectra.n_u
        c = spectra.total
        self._cur = c[:, :nu, nu:]                                  # (F, nu, nr)
        self._cuu = c[:, :nu, :nu]
        # S_rr,b: the reference's spectra summed over each band, (B, nr, nr)
        self.reference_band_sums = spectra.band_sums()[:, nu:, nu:]
        # one-hot band membership, (F, B)
        self._onehot = np.eye(spectra.n_bands)[spectra.band_of]
        # The deconvolution factor H_nom/H(a) at log-spaced nodes, and the
        # (F, Q) weights that interpolate it to the bins (core.model.nodes),
        # folded into the spectra
        self.nodes, self.node_weights = interpolation_nodes(spectra.freqs, NODES_PER_DECADE)
        # (nu, Q, B*nr): row i of C_ur, band indicator and weights folded in
        # (folded band by band: the three-operand einsum took ~0.5 s per model)
        self._cur_rows = fold(self.node_weights, spectra.band_of, spectra.n_bands, self._cur[None])[0]
        # S_ur,b at nominal response, (B, nu, nr); rows with a free response are recomputed
        self._sur_nominal = spectra.band_sums()[:, :nu, nu:]
        self._band_nodes = noisescale.band_node_weights(self._onehot, self.node_weights)

    def _fold_time_blocks(self, spectra, per_block):
        """The per-time-block sums a time-dependent effect (or the noise
        inflation under effects) needs; sets ``per_block`` and the layout
        the residual uses."""
        nu = spectra.n_u
        # A time-dependent effect needs the per-time-block likelihood: one
        # residual per band and block (see "Time blocks" in the module notes).
        self.per_block = bool(per_block or self._blocked)
        bt = spectra.block_totals
        has_blocks = bt is not None and bt.shape[0] >= MIN_TIME_BLOCKS
        if self.per_block and not has_blocks:
            raise ValueError("the per-block likelihood needs spectra with at least "
                             f"{MIN_TIME_BLOCKS} time blocks")
        # With effects the noise inflation is measured on exact per-block
        # residuals (see estimate_noise), so the blocks are kept then too.
        self._exact_blocks = has_blocks and (self.per_block or bool(self.effects))
        if self._exact_blocks:
            # per time block, as _cur_rows: (G, nu, Q, B*nr)
            self._cur_blocks = fold(self.node_weights, spectra.band_of, spectra.n_bands,
                                    bt[:, :, :nu, nu:])
            band = band_sums(spectra.band_of, spectra.n_bands, bt)
            self._sur_blocks, self._srr_blocks = band[:, :, :nu, nu:], band[:, :, nu:, nu:]
        if self.per_block:
            self.n_time_blocks = bt.shape[0]
            self._sur_g, self._srr_g = self._sur_blocks, self._srr_blocks
        else:
            self.n_time_blocks = 1
            self._sur_g = self._sur_nominal[None]
            self._srr_g = self.reference_band_sums[None]

    # --- parameters -------------------------------------------------------
    def unpack(self, theta):
        """theta (W, ndim) -> SUT axes (W, n_u, 3) and deconvolution factors
        ``H_nom(f) / H(f; a)`` at the interpolation nodes (W, n_u, Q) that turn
        the nominally deconvolved SUT spectra into spectra deconvolved by the
        parametric response (``ratio @ self.node_weights.T`` gives them per bin)."""
        theta = np.atleast_2d(theta)
        w, f = theta.shape[0], self.nodes.size
        vecs = np.empty((w, len(self.blocks), 3))
        ratio = np.ones((w, len(self.blocks), f), dtype=complex)
        for k, (b, (so, sr)) in enumerate(zip(self.blocks, self.slices)):
            vecs[:, k] = b.manifold.vectors(theta[:, so])
            r = theta[:, sr]
            if b.free == "gain":
                with np.errstate(all="ignore"):    # wild least-squares steps; the prior rejects them
                    ratio[:, k] = 1.0 / b.family.gain_only_ratio(np.exp(r[:, 0]))
            elif b.free == "all":
                with np.errstate(all="ignore"):    # wild least-squares steps; the prior rejects them
                    ratio[:, k] = self._inverse[k](*self._period_damping(b, r), np.exp(r[:, 2]))
        for e, sl in zip(self.effects, self.effect_slices):
            if not e.blocked:
                ratio[:, e.rows] *= e.factor(self.nodes, theta[:, sl])
        return vecs, ratio

    def block_factors(self, theta):
        """(W, G, n_u, Q) per-time-block factors of the time-dependent
        effects at the nodes (multiplying ``unpack``'s ratio), or None."""
        if not self._blocked:
            return None
        theta = np.atleast_2d(theta)
        g = self.spectra.block_totals.shape[0]
        out = np.ones((theta.shape[0], g, len(self.blocks), self.nodes.size), dtype=complex)
        for e, sl in self._blocked:
            out[:, :, e.rows] *= e.factor(self.nodes, theta[:, sl])
        return out

    def response_values(self, theta):
        """Physical response parameters per channel: dict id -> (W, 3) of
        (period_s, damping, gain), nominal where not free."""
        theta = np.atleast_2d(theta)
        out = {}
        for b, (_, sr) in zip(self.blocks, self.slices):
            if b.family is None:
                continue
            vals = np.tile([b.family.period_s, b.family.damping, b.family.gain], (theta.shape[0], 1))
            r = theta[:, sr]
            if b.free == "gain":
                vals[:, 2] = np.exp(r[:, 0])
            elif b.free == "all":
                vals[:, 0], vals[:, 1] = self._period_damping(b, r)
                vals[:, 2] = np.exp(r[:, 2])
            out[b.channel_id] = vals
        return out

    def bounds(self):
        """(lo, hi) of every parameter under the priors (infinite for the
        angles and the effects' parameters)."""
        lo, hi = np.full(self.ndim, -np.inf), np.full(self.ndim, np.inf)
        for b, (_, sr) in zip(self.blocks, self.slices):
            lo[sr], hi[sr] = b.response_bounds(self.priors)
        return lo, hi

    @staticmethod
    def _period_damping(block, r):
        """(period, damping) from a block's ``(c0_rel, c1_rel, ...)`` columns."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return pendulum.to_physical(r[:, 0], r[:, 1], block.family.period_s,
                                        block.family.damping)

    def log_prior(self, theta):
        theta = np.atleast_2d(theta)
        lp = np.zeros(theta.shape[0])
        pr = self.priors
        for b, (so, sr) in zip(self.blocks, self.slices):
            lp += b.manifold.log_prior(theta[:, so])
            if b.free == "none":
                continue
            r = theta[:, sr]
            lg = r[:, -1] - np.log(b.family.gain)
            bad = np.abs(lg) > np.log(gain_prior_factor(b.family, pr))
            if b.free == "all":
                lp += pendulum.log_prior(r[:, 0], r[:, 1], pr.period_tolerance,
                                         pr.damping_tolerance)
            lp[bad] = -np.inf
        for e, sl in zip(self.effects, self.effect_slices):
            lp += e.log_prior(theta[:, sl])
        return lp

    # --- residual and likelihood -----------------------------------------
    def residual_blocks(self, theta):
        """R_{b,g}(theta), (W, G, B, n_u, n_r), G = 1 unless ``per_block``, in
        the counts of the plug-in point (:mod:`bayescal.core.model.noisescale`)."""
        vecs, ratio = self.unpack(theta)
        return noisescale.rescale_rows(self.plain_residual_blocks(vecs, ratio, theta),
                                       getattr(self.noise, "scale0", None), ratio,
                                       self._band_nodes, self._free_rows)

    def plain_residual_blocks(self, vecs, ratio, theta):
        """The same from unpacked parameters, unscaled; counted as work (core.budget)."""
        charge(vecs.shape[0])
        if self.per_block:
            return self._exact_block_residuals(theta, (vecs, ratio))
        w = vecs.shape[0]
        nb, nr = self.spectra.n_bands, self.spectra.n_r
        t = vecs @ self.ref_pinv                                    # (W, nu, nr)
        r = np.broadcast_to(self._sur_g, (w,) + self._sur_g.shape).copy()
        # one BLAS product per row: (W, Q) @ (Q, B*nr); operands must be
        # contiguous (a transposed view drops matmul off BLAS, 50x slower)
        for j in self._free_rows:
            if j in self._scaled_rows:      # ratio constant in frequency: scale the row
                r[:, 0, :, j, :] *= ratio[:, j, :1, None]
                continue
            r[:, 0, :, j, :] = (np.ascontiguousarray(ratio[:, j]) @ self._cur_rows[j]).reshape(
                w, nb, nr)
        r -= _times_blocks(t, self._srr_g)                            # (W, 1, B, nu, nr)
        return r

    def _exact_block_residuals(self, theta, unpacked=None):
        """(W, G, B, n_u, n_r): the residual of every time block of the
        spectra, with each effect's factor applied per frequency bin."""
        vecs, ratio = self.unpack(theta) if unpacked is None else unpacked
        w = vecs.shape[0]
        nb, nr = self.spectra.n_bands, self.spectra.n_r
        t = vecs @ self.ref_pinv
        g_n = self._cur_blocks.shape[0]
        r = np.broadcast_to(self._sur_blocks, (w,) + self._sur_blocks.shape).copy()
        bf = self.block_factors(theta)
        for j in self._free_rows:
            # one batched product per row: (G, W, Q) @ (G, Q, B*nr)
            rg = np.broadcast_to(ratio[None, :, j], (g_n, w, ratio.shape[2])) if bf is None \
                else ratio[None, :, j] * bf[:, :, j].transpose(1, 0, 2)
            row = np.matmul(np.ascontiguousarray(rg), self._cur_blocks[:, j])
            r[:, :, :, j, :] = row.reshape(g_n, w, nb, nr).transpose(1, 0, 2, 3)
        r -= _times_blocks(t, self._srr_blocks)                       # (W, G, B, nu, nr)
        return r

    def residual(self, theta):
        """R_b(theta) summed over time blocks, shape (W, B, n_u, n_r)."""
        return self.residual_blocks(theta).sum(axis=1)

    #: Per-band noise-scale prior shape (:mod:`.misfit_scale`; inf: Gaussian; fits set it).
    misfit_shape = np.inf
    #: None, or (B,) a lower bound on each band's noise inflation (:mod:`.inflation`).
    inflation_floor = None

    def band_energy(self, theta):
        """(W, B) whitened residual energy per band (Gaussian term ``-q_b``)
        and (B,) its complex degrees of freedom."""
        r = self.residual_blocks(theta)
        arb = (self.noise.A @ r) @ self.noise.B          # batched matmul: ~2x einsum here
        q = np.sum((arb * r.conj()).real, axis=(1, 3, 4))
        return q, np.full(q.shape[1], float(r.shape[1] * r.shape[3] * r.shape[4]))

    def log_likelihood(self, theta):
        if misfit_scale.PER_CHANNEL:      # a noise scale per SUT channel
            return channel_scale.log_likelihood(self, theta)
        return misfit_scale.band_loglik(*self.band_energy(theta), self.misfit_shape,
                                        getattr(self.noise, "weight", None))

    def log_prob(self, theta):
        """Vectorised log posterior for emcee: theta (W, ndim) -> (W,)."""
        theta = np.atleast_2d(theta)
        lp = self.log_prior(theta)
        ok = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if ok.any():
            out[ok] = lp[ok] + self.log_likelihood(theta[ok])
        return out

    def _whiten(self, theta, factors):
        la, lb = factors
        r = self.residual_blocks(np.atleast_2d(theta))[0]
        return np.einsum("bji,gbjk,gbkl->gbil", la.conj(), r, lb)

    def whitened_residual(self, theta, factors):
        """Real vector whose squared norm is ``-log L`` (for least squares)."""
        z = self._whiten(theta, factors)
        return np.concatenate([z.real.ravel(), z.imag.ravel()])

    def likelihood_residual(self, theta):
        """The whitened residual at one ``theta`` with the noise model as
        set: its squared norm is the weighted Gaussian ``-log L``."""
        return self.whitened_residual(theta, self.noise.cholesky())

    # --- noise model -------------------------------------------------------
    def estimate_noise(self, theta0):
        """Plug-in noise model at ``theta0`` (see module docstring); sets and
        returns ``self.noise``."""
        sp = self.spectra
        nu = sp.n_u
        vecs, ratio = self.unpack(theta0)
        t = (vecs @ self.ref_pinv)[0]
        rho_g, sigma = self._residual_covariance(theta0, t, ratio)
        sigma_inv = np.linalg.inv(sigma)
        b_inv = np.linalg.inv(self.reference_band_sums)
        b_inv_g = np.linalg.inv(self._srr_g)                         # (G, B, nr, nr)
        r_k, adjacent, dof = self._scatter_residuals(theta0, t, rho_g, b_inv)
        scatter = lag_one_scatter(lambda x, y: np.einsum("bij,kbjl,blm,kbim->b", sigma_inv, x,
                                                         b_inv, y.conj()).real, r_k, adjacent)
        p = nu * sp.n_r
        c = shrunk_inflation(dof * scatter / p, r_k.shape[0] * p, floor=self.inflation_floor)
        scale0 = noisescale.noise_scale(ratio, self._band_nodes, self._free_rows)[0]
        self.noise = NoiseModel(A=sigma_inv / c[:, None, None], B=b_inv_g, sigma=sigma,
                                inflation=c, scale0=scale0,
                                weight=plugin.band_weights(band_dof(sp), nu))
        return self.noise

    def _residual_covariance(self, theta0, t, ratio):
        """Per-bin deconvolution factors ``rho_g`` (G, n_u, F) at ``theta0``
        and the per-bin residual covariance ``Sigma_b`` (B, n_u, n_u)."""
        sp = self.spectra
        nu = sp.n_u
        bf = self.block_factors(theta0)
        if bf is None:
            rho_g = (ratio[0] @ self.node_weights.T)[None]                # (1, nu, F)
            c_g = sp.total[None]
        else:
            rho_g = (ratio[0][None] * bf[0]) @ self.node_weights.T        # (G, nu, F)
            c_g = sp.block_totals
        # per-bin residual power summed in each band: sum e e^H
        yu_yu = np.einsum("gif,gfij,gjf->fij", rho_g, c_g[:, :, :nu, :nu], rho_g.conj())
        yu_yr = np.einsum("gif,gfij->fij", rho_g, c_g[:, :, :nu, nu:])
        e = (yu_yu - t @ yu_yr.conj().transpose(0, 2, 1) - yu_yr @ t.T
             + t @ sp.total[:, nu:, nu:] @ t.T)
        sum_e = np.einsum("fb,fij->bij", self._onehot, e)
        n_bins = sp.bins_per_band * sp.n_segments
        return rho_g, sum_e / n_bins[:, None, None]

    def _scatter_residuals(self, theta0, t, rho_g, b_inv):
        """The residuals whose scatter measures the inflation: (K, B, n_u,
        n_r), the indices of overlapping neighbours and the degrees-of-freedom
        correction (B,) or 1."""
        sp = self.spectra
        nu = sp.n_u
        # per-segment band residuals, the band's response ratio at its centre
        if self._exact_blocks:
            # An effect's factor can vary within a band (a delay's phase does):
            # the residuals of the time blocks, which keep every bin, carry it
            # exactly; a per-segment band residual would not.
            # A misfit common to the blocks (R_g = D S_rr,g for one D per band)
            # is removed first, so that what the model leaves does not pass
            # for noise (with G blocks of K/G segments it would weigh K/G
            # times more than in per-segment residuals); one block's worth of
            # scatter goes with it, hence the G / (G - 1).
            r_k = self._exact_block_residuals(theta0)[0]                # (G, B, nu, nr)
            common = r_k.sum(axis=0) @ b_inv                            # (B, nu, nr)
            r_k = r_k - np.einsum("bij,gbjk->gbik", common, self._srr_blocks)
            # blocks share one overlapping segment pair at most: no lag term
            # (after the removal it would measure the removal, not overlap)
            share = np.einsum("bij,gbji->gb", b_inv, self._srr_blocks).real / sp.n_r
            return r_k, np.zeros(0, int), 1.0 / (1.0 - np.sum(share ** 2, axis=0))
        rho = rho_g[0]
        rho_b = np.stack([rho[:, sp.band_of == b].mean(axis=1) for b in range(sp.n_bands)])
        seg = sp.per_segment
        r_k = rho_b[None, :, :, None] * seg[:, :, :nu, nu:] - np.einsum(
            "ij,kbjl->kbil", t, seg[:, :, nu:, nu:])
        return r_k, overlapping_segments(sp.segment_starts, sp.nperseg), 1.0

    def adopt_noise(self, noise):
        """Set the noise model to ``noise`` (from a model on the same
        spectra), its reference factor recomputed for this model's layout
        (band sums, or per time block)."""
        b = noise.B
        if b.shape[0] != self.n_time_blocks:
            b = np.linalg.inv(self._srr_g)
        self.noise = NoiseModel(A=noise.A, B=b, sigma=noise.sigma, inflation=noise.inflation,
                                scale0=getattr(noise, "scale0", None),
                                weight=getattr(noise, "weight", None))
        return self.noise

    def standardized_band_residuals(self, theta):
        """(B, n_u) chi-like misfit per band and SUT channel at ``theta``:
        the whitened residual energy of each row divided by its expectation
        (``n_r``); about 1 where the model fits."""
        # the block-summed residual has covariance Sigma_b (x) S_rr,b^T in
        # either layout: one scale for models with and without time blocks
        la = np.linalg.cholesky(self.noise.A)
        lb = np.linalg.cholesky(np.linalg.inv(self.reference_band_sums))
        r = self.residual(np.atleast_2d(theta))[0]
        z = np.einsum("bji,bjk,bkl->bil", la.conj(), r, lb)
        return np.sum(np.abs(z) ** 2, axis=2) / self.spectra.n_r


def band_sums(band_of, n_bands, per_bin):
    """``einsum("fb,gfij->gbij", onehot(band_of), per_bin)``, the (G, B, i, j)
    band sums of per-bin matrices (G, F, i, j). Each band's bins are summed
    by numpy's own loop (no BLAS product), so the sums are the same bits
    whatever the number of BLAS threads (the einsum loops over all five
    indices, several times slower)."""
    dtype = np.result_type(per_bin.dtype, np.float64)
    out = np.empty((per_bin.shape[0], n_bands) + per_bin.shape[2:], dtype=dtype)
    for b in range(n_bands):
        out[:, b] = per_bin[:, band_of == b].sum(axis=1, dtype=dtype)
    return out


def _times_blocks(t, s):
    """``t @ s`` for every walker and block, (W, G, B, n_u, n_r), as one
    BLAS product: ``t`` (W, n_u, n_r), ``s`` (G, B, n_r, n_r)."""
    w, nu, nr = t.shape
    g, b = s.shape[:2]
    flat = s.transpose(2, 0, 1, 3).reshape(nr, g * b * nr)
    out = np.ascontiguousarray(t).reshape(w * nu, nr) @ flat
    return out.reshape(w, nu, g, b, nr).transpose(0, 2, 3, 1, 4)
