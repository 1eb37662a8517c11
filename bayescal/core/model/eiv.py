"""The likelihood when both sensors are noisy (errors in variables).

:class:`EIVModel` is :class:`~bayescal.core.model.likelihood.Model` with the
reference's self-noise put back into the residual and the residual's exact
covariance (see :mod:`bayescal.core.model.refnoise` for the statistic and its
derivation, docs/validation/errors_in_variables.md for the reasoning and the checks).
Parameters, priors, response ratios and the sampler are the base model's;
what changes is the residual, its noise model and the likelihood:

    log L = -1/2 sum_b x_b^T W_b x_b,   x_b = [Re vec R_b; Im vec R_b],
    W_b = V_b^-1 / c_b,

``V_b`` the Wishart covariance of the statistic at the least-squares point and
``c_b`` the inflation measured from the per-segment statistics. In mode
``estimate`` each SUT row of ``x`` is taken to the counts of that point
(:mod:`bayescal.core.model.noisescale`), as in the base model. In mode
``estimate`` the reference's noise coefficients are profiled out in closed form
per walker.
Effects of model criticism that do not depend on time work as on the base
model; time-dependent ones (a drifting clock, which needs the per-block
likelihood) are not available on this model: model criticism then uses the
base model (:func:`bayescal.criticism.search`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import noisescale, plugin, refnoise
from ..spectra.dof import band_dof
from .inflation import lag_one_scatter, overlapping_segments, shrunk_inflation
from .likelihood import Model
from .noise_range import NoiseRange
from ..priors import Priors


#: Walkers whose profiled statistic is evaluated at once: the temporaries of
#: the profile (about 40 kB per walker on a 14-band 3+3 pair) stay a few MiB
#: when the sampler asks for thousands of walkers at a time.
WALKER_BLOCK = 128


@dataclass
class EIVNoise:
    """Plug-in noise model of :class:`EIVModel`."""

    cov: np.ndarray        # (B, 2m, 2m) covariance V_b of the band statistic
    W: np.ndarray          # (B, 2m, 2m) precision V_b^-1 / c_b
    inflation: np.ndarray  # (B,) c_b
    along: np.ndarray      # (n_r,) SUT channel along each reference channel
    rho: np.ndarray        # (n_r, 2) noise coefficients at the plug-in point (mode estimate)
    factor: np.ndarray | None = None   # (B, 2m, 2m) F with W = F F^T
    rank: np.ndarray | None = None     # (B,) directions the statistic varies in
    scale0: np.ndarray | None = None   # (n_u, B) |H_nom / H(a)| per band at the plug-in point
    weight: np.ndarray | None = None   # (B,) band weights for the plug-in's own error (core.model.plugin)

    def cholesky(self):
        """Factor F with ``W = F F^T`` per band (whitening: ``F^T x``), each
        band's weight folded in."""
        if self.weight is None:
            return self.factor
        return self.factor * np.sqrt(self.weight)[:, None, None]


class EIVModel(Model):
    """Model with both sensors' self-noise; ``ref_noise`` in ``("equal",
    "estimate", "fixed")``. ``known_noise`` (mode ``fixed``): the reference's
    self-noise per band and reference channel (B, n_r), band sums in the
    spectra's units (:func:`bayescal.core.model.refnoise.band_sums_of_psd`), e.g.
    from a third co-located sensor (``bayescal noise``) or the user."""

    def __init__(self, spectra, ref_vectors, blocks, priors=Priors(), ref_noise="estimate",
                 effects=(), known_noise=None):
        if ref_noise not in ("equal", "estimate", "fixed"):
            raise ValueError("EIVModel needs ref_noise 'equal', 'estimate' or 'fixed', not "
                             f"{ref_noise!r}")
        if (ref_noise == "fixed") != (known_noise is not None):
            raise ValueError("known_noise goes with ref_noise 'fixed' (and only with it)")
        if any(e.blocked for e in effects):
            raise ValueError("time-dependent effects need the per-block base Model")
        super().__init__(spectra, ref_vectors, blocks, priors, effects=effects)
        self.ref_noise = ref_noise
        self.known_noise = None if known_noise is None else np.asarray(known_noise, float)
        if self.known_noise is not None and self.known_noise.shape != (spectra.n_bands,
                                                                         spectra.n_r):
            raise ValueError(f"known_noise must be (bands, reference channels) = "
                             f"{(spectra.n_bands, spectra.n_r)}, not {self.known_noise.shape}")
        nu = spectra.n_u
        self._shapes = refnoise.noise_shapes(spectra)                     # (B, nr, 2)
        # mode 'estimate': the reference's noise is kept within what the
        # spectra admit (never negative beyond their sampling error, never
        # more than the incoherent power they show)
        self._bounds = (NoiseRange(self._shapes, *refnoise.admissible_noise(spectra))
                        if ref_noise == "estimate" else None)
        # mode 'equal' has combinations of the statistic with (near) zero
        # variance whose plug-in error would dominate: directions under 1 %
        # of the largest variance are dropped; 'estimate' keeps everything
        self._rtol = 1e-2 if ref_noise == "equal" else 1e-10
        cuu = np.real(np.einsum("fii->fi", self._cuu))
        self._suu_nominal = np.einsum("fb,fi->bi", self._onehot, cuu)      # (B, nu)
        # each band's bins (sums band by band, in numpy's own loops: the
        # three- and four-operand einsums over all bins and bands cost a
        # 2-hour pair's model 0.04 s to build and each noise estimate 0.01 s)
        self._band_bins = [np.flatnonzero(spectra.band_of == b) for b in range(spectra.n_bands)]
        self._cuu_rows = np.stack([np.einsum("fq,fi->iq", self.node_weights[f], cuu[f])
                                   for f in self._band_bins], axis=-1)      # (nu, Q, B)
        self._k = (spectra.bins_per_band * spectra.n_segments).astype(float)
        self._m = nu * spectra.n_r
        # reference channel of each entry of a flattened (n_u, n_r) residual
        self._column_of = np.eye(spectra.n_r)[np.arange(self._m) % spectra.n_r]

    # --- the statistic ------------------------------------------------------
    def _parts(self, theta):
        """Plain residual ``r0`` (W, B, nu, nr), the noise terms with unit
        ratio ``nt`` (W, B, nu, nr; column k is ``(T e_k) n_u,i(k)``) and T."""
        theta = np.atleast_2d(theta)
        vecs, ratio = self.unpack(theta)
        t = vecs @ self.ref_pinv
        r0 = self.plain_residual_blocks(vecs, ratio, theta)[:, 0]
        sur = r0 + np.einsum("wij,bjk->wbik", t, self.reference_band_sums)
        suu = np.broadcast_to(self._suu_nominal, (theta.shape[0],) + self._suu_nominal.shape).copy()
        for j in self._free_rows:
            suu[:, :, j] = (np.abs(ratio[:, j]) ** 2) @ self._cuu_rows[j]
        n_u = suu - np.einsum("wbij,wij->wbi", sur, t)                     # complex, E real
        along = self.noise.along
        nt = t[:, None, :, :] * n_u[:, :, along][:, :, None, :]
        return r0, nt, t

    def _noise_columns(self, nt):
        """(W, B, 2m, n_r) real statistic of reference channel ``k``'s noise
        term at unit size: ``nt``'s column ``k`` alone, as :func:`refnoise.as_real`
        lays it out (entry ``i n_r + k`` and its imaginary part); ``B`` is
        ``nt``'s (1 for terms the same in every band)."""
        w, b, nu, nr = nt.shape
        flat = nt.reshape(w, b, nu * nr)
        onehot = self._column_of                                          # (m, nr)
        return np.concatenate([flat.real[..., None] * onehot,
                               flat.imag[..., None] * onehot], axis=2)

    def statistic(self, theta, w=None):
        """``x`` (W, B, 2m) and the noise coefficients used (W, n_r, 2)."""
        if self.ref_noise in ("estimate", "fixed"):
            return self._estimate_statistic(theta, w)
        r0, nt, _ = self._parts(theta)      # mode 'equal': rho = 1
        rho = np.zeros((r0.shape[0], nt.shape[-1], 2))
        rho[:, :, 0] = 1.0
        return refnoise.as_real(r0) + refnoise.as_real(nt), rho

    def _estimate_statistic(self, theta, w):
        """Mode ``estimate``: the plain residual plus ``T diag(d)``, ``d`` the
        reference's noise as a combination of fixed spectral shapes
        (:func:`bayescal.core.model.refnoise.noise_shapes`), profiled out. Mode
        ``fixed``: ``d`` the known noise (coefficients returned as zeros)."""
        x, coef, _ = self._estimate_parts(theta, w)
        return x, coef

    def _estimate_parts(self, theta, w):
        """:meth:`_estimate_statistic`'s ``(x, coefficients)`` and the
        quadratic form ``x^T W x`` per band (W, B), evaluated
        :data:`WALKER_BLOCK` walkers at a time (each walker's values are its
        own: the blocks bound the memory, not the numbers)."""
        theta = np.atleast_2d(theta)
        parts = [self._estimate_block(theta[i:i + WALKER_BLOCK], w)
                 for i in range(0, max(theta.shape[0], 1), WALKER_BLOCK)]
        if len(parts) == 1:
            return parts[0]
        return tuple(np.concatenate(p) for p in zip(*parts))

    def _estimate_block(self, theta, w):
        """:meth:`_estimate_parts` for one block of walkers."""
        x0, u = self._profile_inputs(theta)
        if self.ref_noise == "fixed":
            w = self.noise.W if w is None else w
            x = x0 + (u * self.known_noise[None, :, None, :]).sum(axis=-1)
            q = (x * refnoise.band_matmul(w, x[..., None])[..., 0]).sum(axis=-1)
            return x, np.zeros((x.shape[0], u.shape[-1], 2)), q
        weight = getattr(self.noise, "weight", None) if w is None else None
        if w is None:
            w = self.noise.W
        if weight is not None:
            # profile the coefficients (shared by all bands) out of the
            # likelihood that is sampled, each band weighted
            # (bayescal.core.model.plugin); q is returned unweighted, per band
            coef, term, q = refnoise.profile_columns(x0, u, self._shapes,
                                                     w * weight[:, None, None], self._bounds)
            return x0 + term, coef, q / weight
        coef, term, q = refnoise.profile_columns(x0, u, self._shapes, w, self._bounds)
        return x0 + term, coef, q

    def _profile_inputs(self, theta):
        """The plain statistic ``x0`` (W, B, 2m) and the reference noise
        terms at unit size ``u`` (W, B, 2m, n_r), in the counts of the
        plug-in point."""
        theta = np.atleast_2d(theta)
        vecs, ratio = self.unpack(theta)
        t = vecs @ self.ref_pinv
        x0 = refnoise.as_real(self.plain_residual_blocks(vecs, ratio, theta)[:, 0])
        u = self._noise_columns(t[:, None])             # the same in every band: built once
        f = self._row_factor(ratio)
        if f is not None:
            return x0 * f, u * f[..., None]
        return x0, np.broadcast_to(u, x0.shape + u.shape[-1:])

    def _row_factor(self, ratio):
        """(W, B, 2m) ``|rho(a0)| / |rho(a)|`` per entry of the statistic
        (each SUT row in the counts of the plug-in point,
        :mod:`bayescal.core.model.noisescale`), or None before a noise model."""
        scale0 = getattr(self.noise, "scale0", None)
        if scale0 is None:
            return None
        f = scale0[None] / noisescale.noise_scale(ratio, self._band_nodes, self._free_rows)
        f = np.repeat(f.transpose(0, 2, 1), self.spectra.n_r, axis=2)          # (W, B, m)
        return np.concatenate([f, f], axis=2)

    # --- likelihood --------------------------------------------------------
    def residual_blocks(self, theta):
        """R per band as a (W, 1, B, n_u, n_r) complex array (for the
        base class's diagnostics)."""
        x, _ = self.statistic(theta)
        m = self._m
        r = (x[..., :m] + 1j * x[..., m:]).reshape(x.shape[:2] + (self.spectra.n_u, -1))
        return r[:, None]

    def band_energy(self, theta):
        """(W, B) half the statistic's chi-square per band and (B,) half its
        rank (the complex degrees of freedom)."""
        if (self.ref_noise in ("estimate", "fixed")
                and type(self)._estimate_statistic is EIVModel._estimate_statistic):
            return 0.5 * self._estimate_parts(theta, None)[2], 0.5 * self.noise.rank
        x, _ = self.statistic(theta)
        wx = refnoise.band_matmul(self.noise.W, x[..., None])[..., 0]      # (W, B, 2m)
        return 0.5 * np.sum(x * wx, axis=-1), 0.5 * self.noise.rank

    def _whiten(self, theta, factors):
        x, _ = self.statistic(np.atleast_2d(theta))
        return (np.swapaxes(factors, -1, -2) @ x[0][..., None])[..., 0] / np.sqrt(2.0)

    def whitened_residual(self, theta, factors):
        """Real vector whose squared norm is ``-log L``."""
        return self._whiten(theta, factors).ravel()

    def standardized_band_residuals(self, theta):
        """(B, n_u) misfit per band and SUT channel, about 1 where the model
        fits: each row's statistic against its own marginal covariance."""
        x, _ = self.statistic(np.atleast_2d(theta))
        x = x[0]
        nu, nr, m = self.spectra.n_u, self.spectra.n_r, self._m
        out = np.empty((self.spectra.n_bands, nu))
        for i in range(nu):
            idx = np.r_[i * nr:(i + 1) * nr, m + i * nr:m + (i + 1) * nr]
            cov = self.noise.cov[:, idx][:, :, idx] * self.noise.inflation[:, None, None]
            w, _, rank = _pseudo_inverse(cov, self._rtol)
            xi = x[:, idx]
            out[:, i] = np.einsum("bi,bij,bj->b", xi, w, xi) / rank
        return out

    # --- noise model -------------------------------------------------------
    def estimate_noise(self, theta0):
        """Plug-in noise model at ``theta0``: the statistic's Wishart
        covariance per band, the noise coefficients (mode ``estimate``) and the
        inflation."""
        sp = self.spectra
        nu, nr = sp.n_u, sp.n_r
        theta0 = np.atleast_2d(theta0)[:1]
        vecs, ratio = self.unpack(theta0)
        t = (vecs @ self.ref_pinv)[0]
        along = np.argmax(np.abs(t), axis=0)
        rho_f = ratio[0] @ self.node_weights.T                                   # (nu, F)
        d = np.concatenate([rho_f, np.ones((nr, rho_f.shape[1]))], axis=0)  # (n, F)
        s_band = np.stack([np.einsum("if,fij,jf->ij", d[:, f], sp.total[f], d[:, f].conj())
                           for f in self._band_bins])                       # (B, n, n)
        c_band = s_band / self._k[:, None, None]
        rho = np.zeros((nr, 2))
        rho[:, 0] = 1.0 if self.ref_noise == "equal" else 0.0
        self.noise = EIVNoise(cov=None, W=None, inflation=np.ones(sp.n_bands), along=along, rho=rho)
        a0, b0, _ = refnoise.selectors(nu, nr, t)
        data_terms = self.ref_noise == "equal"     # the SUT's noise read from the data
        cov = np.stack([refnoise.real_covariance(
            [(a0, b0)] + (refnoise.noise_terms(t, along, rho[:, 0]) if data_terms else []),
            c_band[b], self._k[b]) for b in range(sp.n_bands)])
        w, factor, rank = _pseudo_inverse(cov, self._rtol)
        if not data_terms:
            rho = self.statistic(theta0, w=w)[1][0]
        # inflation from per-segment statistics (band-centre response ratio)
        rho_b = np.stack([rho_f[:, sp.band_of == b].mean(axis=1) for b in range(sp.n_bands)])
        db = np.concatenate([rho_b, np.ones((sp.n_bands, nr))], axis=1)     # (B, n)
        seg = db[None, :, :, None] * sp.per_segment * db[None, :, None, :].conj()
        if data_terms:
            x_k = np.stack([refnoise.as_real(self._segment_statistic(seg[:, b], t, along,
                                                                     rho[:, 0]))
                            for b in range(sp.n_bands)], axis=1)          # (K, B, 2m)
        else:   # the plain residual with each segment's share of the fitted noise
            d = (self.known_noise if self.ref_noise == "fixed"
                 else np.sum(rho[None] * self._shapes, axis=2)) / seg.shape[0]   # (B, nr)
            x_k = np.stack([refnoise.as_real(self._segment_statistic(seg[:, b], t, along, None)
                                             + t * d[b][None, :])
                            for b in range(sp.n_bands)], axis=1)
        scatter = lag_one_scatter(lambda x, y: np.einsum("kbi,bij,kbj->b", x, w, y), x_k,
                                  overlapping_segments(sp.segment_starts, sp.nperseg))
        c = shrunk_inflation(scatter / rank, x_k.shape[0] * rank, floor=self.inflation_floor)
        self.noise = EIVNoise(cov=cov, W=w / c[:, None, None], inflation=c, along=along, rho=rho,
                              factor=factor / np.sqrt(c)[:, None, None], rank=rank,
                              weight=plugin.band_weights(band_dof(sp), nu + nr))
        if not data_terms:      # mode estimate: the noise held in the SUT's counts
            self.noise.scale0 = noisescale.noise_scale(ratio, self._band_nodes,
                                                       self._free_rows)[0]
        return self.noise

    def on_bound(self, theta):
        """Whether the reference's profiled noise at ``theta`` lies on an end
        of the range the spectra admit (:func:`refnoise.admissible_noise`):
        there the spectra cannot tell it from the SUT's, and the range, not
        the data, places it."""
        if self._bounds is None or self.noise is None or self.noise.W is None:
            return False
        coef = self.statistic(np.atleast_2d(theta)[:1])[1][0]
        d = (self._shapes * coef[None]).sum(axis=-1)                       # (B, nr)
        lo, hi = self._bounds.lower, self._bounds.upper
        tol = 1e-6 * (hi - lo)
        return bool(np.any((d >= hi - tol) | (d <= lo + tol)))

    @staticmethod
    def _segment_statistic(s, t, along, weights):
        """The statistic of every segment's band matrix ``s`` (K, n, n)."""
        nu, nr = t.shape
        a0, b0, _ = refnoise.selectors(nu, nr, t)
        out = a0 @ s @ b0
        for a, b in ([] if weights is None else refnoise.noise_terms(t, along, weights)):
            out = out + a @ s @ b
        return out

    def adopt_noise(self, noise):
        self.noise = noise
        return noise

    def reference_noise_psd(self, theta):
        """(B, n_r) the reference's self-noise PSD, (m/s)^2/Hz, per band at
        ``theta``: the fitted shapes (estimate) or the SUT's own noise (equal)."""
        theta = np.atleast_2d(theta)[:1]
        sp = self.spectra
        _, rho = self.statistic(theta)
        if self.ref_noise in ("estimate", "fixed"):
            d = (self.known_noise if self.ref_noise == "fixed"
                 else np.sum(rho[0][None] * self._shapes, axis=2))
            return d / (sp.bins_per_band * sp.n_segments)[:, None] * sp.psd_scale
        _, nt, t = self._parts(theta)
        cols = np.arange(t.shape[2])
        n_along = np.real(nt[0][:, self.noise.along, cols] / t[0][self.noise.along, cols])
        d = n_along
        return d / (sp.bins_per_band * sp.n_segments)[:, None] * sp.psd_scale


def _pseudo_inverse(cov, rtol):
    """Per band: the pseudo-inverse of a covariance, a factor ``F`` with
    ``pinv = F F^T`` and its rank. Some combinations of the statistic are
    identically zero (e.g. with T = I the imaginary diagonal of ``T^-1 R``:
    the SUT's noise estimate cancels it exactly); they carry no information
    and are dropped."""
    lam, u = np.linalg.eigh(cov)
    keep = lam > rtol * lam[:, -1:]
    inv_sqrt = np.where(keep, 1.0 / np.sqrt(np.where(keep, lam, 1.0)), 0.0)
    factor = u * inv_sqrt[:, None, :]
    return factor @ factor.transpose(0, 2, 1), factor, keep.sum(axis=1)
