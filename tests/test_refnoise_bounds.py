"""The reference's noise is estimated within what the spectra admit: never
above the incoherent power the spectra show, never below zero, each end
widened by that power's sampling error. The bounds are the closed form of a
known case, and the bounded profile is the constrained minimum scipy finds."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from bayescal.core.model import noise_range, refnoise


class _Spectra:
    """Band sums of a pair with the SUT seeing the ground g and the reference
    seeing g plus its own noise n: S_uu = G, S_ur = G, S_rr = G + N."""

    def __init__(self, g, n, bins=(12, 30), segments=40):
        nb = len(bins)
        self.n_u, self.n_r = g.shape[0], g.shape[0]
        top = np.concatenate([g, g], axis=1)
        bottom = np.concatenate([g, g + n], axis=1)
        self._s = np.stack([np.concatenate([top, bottom], axis=0) * (b * segments) for b in bins])
        self.bins_per_band = np.array(bins)
        self.n_segments = segments
        assert self._s.shape[0] == nb

    def band_sums(self):
        return self._s


def test_admissible_noise_is_the_reference_noise_when_the_sut_is_quiet():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((2, 2)) + 1j * rng.standard_normal((2, 2))
    g = a @ a.conj().T + np.eye(2)
    n = np.diag([0.3, 0.05])
    sp = _Spectra(g, n)
    lower, upper = refnoise.admissible_noise(sp)
    k = sp.bins_per_band * sp.n_segments
    left = k - sp.n_u
    # exact band sums (no sampling error): the noise itself, scaled as an
    # estimate from K - n_u degrees of freedom is, plus three standard errors;
    # below, zero less the same three standard errors
    power = np.diag(n)[None] * k[:, None] * (k / left)[:, None]
    np.testing.assert_allclose(upper, power * (1 + 3 / np.sqrt(left))[:, None], rtol=1e-9)
    np.testing.assert_allclose(lower, -power * (3 / np.sqrt(left))[:, None], rtol=1e-9)


def _problem(seed, nw=6, nb=4, nu=2, nr=2):
    rng = np.random.default_rng(seed)
    m = nu * nr
    x0 = rng.standard_normal((nw, nb, 2 * m))
    u = rng.standard_normal((nw, nb, 2 * m, nr))
    a = rng.standard_normal((nb, 2 * m, 2 * m))
    w = a @ a.transpose(0, 2, 1) + 0.5 * np.eye(2 * m)
    shapes = rng.uniform(0.2, 1.0, (nb, nr, 2))
    upper = rng.uniform(0.3, 1.5, (nb, nr))
    lower = -rng.uniform(0.02, 0.3, (nb, nr))
    return x0, u, shapes, w, (lower, upper)


def _objective(c, x0, u, shapes, w):
    d = (shapes * c.reshape(-1, 2)[None]).sum(axis=-1)               # (B, nr)
    x = x0 + (u * d[:, None, :]).sum(axis=-1)
    return float(np.einsum("bi,bij,bj->", x, w, x))


@pytest.mark.parametrize("seed", range(5))
def test_bounded_profile_is_the_constrained_minimum(seed):
    x0, u, shapes, w, (lower, upper) = _problem(seed)
    c, _, q = refnoise.profile_columns(x0, u, shapes, w, (lower, upper))
    nr = shapes.shape[1]
    free, _, q_free = refnoise.profile_columns(x0, u, shapes, w)
    for k in range(x0.shape[0]):
        d = (shapes * c[k][None]).sum(axis=-1)
        assert np.all(d <= upper * (1 + 1e-9)) and np.all(d >= lower * (1 + 1e-9))

        def noise(v):
            return (shapes * v.reshape(nr, 2)[None]).sum(axis=-1).ravel()
        cons = [{"type": "ineq", "fun": lambda v: upper.ravel() - noise(v)},
                {"type": "ineq", "fun": lambda v: noise(v) - lower.ravel()}]
        best = min((minimize(_objective, start, args=(x0[k], u[k], shapes, w),
                             constraints=cons, method="SLSQP",
                             options={"ftol": 1e-14, "maxiter": 500})
                    for start in (np.zeros(2 * nr), np.full(2 * nr, 0.1))),
                   key=lambda r: r.fun)
        ours = _objective(c[k].ravel(), x0[k], u[k], shapes, w)
        assert ours == pytest.approx(q[k].sum(), rel=1e-9)
        assert ours <= best.fun * (1 + 1e-6) + 1e-9, (ours, best.fun)
        # the bounded minimum is never below the free one
        assert q[k].sum() >= q_free[k].sum() - 1e-9 * abs(q_free[k].sum())
    # the cases include walkers whose free minimum breaks a bound
    d_free = (shapes[None] * free[:, None]).sum(axis=-1)
    assert np.any((d_free > upper[None]) | (d_free < lower[None]))


def test_polygon_minimum_matches_scipy():
    """The exact 2-D block solve: the free minimum when feasible, else the
    best point on the polygon's edges, as SLSQP finds it (100 random cases,
    a centrally symmetric polygon, bounded or not, as the profile builds)."""
    rng = np.random.default_rng(1)
    for _ in range(100):
        a = rng.standard_normal((2, 2))
        h = a @ a.T + 0.1 * np.eye(2)
        g = 3 * rng.standard_normal(2)
        s = rng.uniform(0.2, 1.0, (4, 2))
        up = rng.uniform(0.3, 1.5, 4)
        rows = np.concatenate([-s, s])
        rhs = np.concatenate([up, up])
        x = noise_range.polygon_minimum(h[None], g[None], noise_range.polygon_edges(rows, rhs))[0]

        def f(v):
            return v @ h @ v + 2 * g @ v
        ref = minimize(f, np.zeros(2), constraints=[{"type": "ineq",
                                                     "fun": lambda v: rhs - rows @ v}],
                       method="SLSQP", options={"ftol": 1e-15})
        assert np.all(rows @ x <= rhs + 1e-9)
        assert f(x) <= ref.fun + 1e-7 * abs(ref.fun) + 1e-9


def _faces_of(poly):
    """Every face of a polygon as (p, Z): the plane (free), each edge's
    line, each vertex (the ends of the edges' feasible segments)."""
    out, vertices = [(np.zeros(2), np.eye(2))], []
    for x0, v, lo, hi in zip(poly.x0, poly.v, poly.lo, poly.hi):
        out.append((x0, v[:, None]))
        vertices += [x0 + t * v for t in (lo, hi) if np.isfinite(t)]
    vertices = np.unique(np.round(np.array(vertices), 12), axis=0)
    return out + [(x, np.zeros((2, 0))) for x in vertices]


def _enumerated_minimum(h, g, polygons):
    """The bounded minimum by brute force: the minimum over every product of
    faces of the objective's minimiser on that face's affine hull, among
    those inside every polygon (the minimum lies inside one face, where it
    is that face's minimiser)."""
    import itertools
    from scipy.linalg import block_diag
    best, arg = np.inf, None
    for combo in itertools.product(*(_faces_of(p) for p in polygons)):
        p = np.concatenate([f[0] for f in combo])
        z = block_diag(*[f[1] for f in combo])
        y = (np.linalg.lstsq(z.T @ h @ z, -z.T @ (h @ p + g), rcond=None)[0]
             if z.shape[1] else np.zeros(0))
        c = p + z @ y
        inside = all(np.all(poly.a @ c[2 * k:2 * k + 2] <= poly.b + 1e-9 * np.abs(poly.b).max())
                     for k, poly in enumerate(polygons))
        f = c @ h @ c + 2 * g @ c
        if inside and f < best:
            best, arg = f, c
    return arg


def test_bounded_minimum_is_the_best_face_by_enumeration():
    """The profile's bounded minimum (a face guessed, solved exactly and
    checked by its multipliers; block coordinate descent where the guess
    fails) against brute force over every product of faces, on 150 random
    walkers of two channels whose minima lie inside, on edges and at
    vertices of the polygons; both routes of :meth:`NoiseRange.minimum`
    are taken."""
    rng = np.random.default_rng(7)
    nb, nr, nw = 3, 2, 150
    shapes = rng.uniform(0.2, 1.0, (nb, nr, 2))
    rng_ = noise_range.NoiseRange(shapes, -rng.uniform(0.02, 0.3, (nb, nr)),
                                  rng.uniform(0.3, 1.5, (nb, nr)))
    a = rng.standard_normal((nw, 2 * nr, 2 * nr))
    h = a @ np.swapaxes(a, 1, 2) + 0.3 * np.eye(2 * nr)
    grad = rng.standard_normal((nw, 2 * nr)) * rng.uniform(0.1, 4.0, (nw, 1))
    free = -np.linalg.solve(h, grad[..., None])[..., 0].reshape(nw, nr, 2)
    c = rng_.minimum(h, grad, free)
    guess_ok = rng_.face_minimum(h, grad, rng_._guess(free))[1]
    assert 0.2 < guess_ok.mean() < 0.95           # both routes taken
    kinds = set()
    for w in range(nw):
        ref = _enumerated_minimum(h[w], grad[w], rng_.polygons)
        np.testing.assert_allclose(c[w].ravel(), ref, rtol=1e-7, atol=1e-9 * np.abs(ref).max())
        for k, poly in enumerate(rng_.polygons):
            kinds.add(int(np.sum(poly.b - poly.a @ c[w, k] <= 1e-9 * np.abs(poly.b).max())))
    assert {0, 1, 2} <= kinds                      # inside, on an edge, at a vertex


def test_face_numbers_name_the_faces_the_sweep_lands_on():
    """Channels whose polygons have different numbers of edges: the face
    number a sweep reports for each channel's point is the table entry
    whose affine map holds that point (a vertex's is the point itself)."""
    rng = np.random.default_rng(3)
    for _ in range(50):          # the first draw whose channels' polygons differ in edges
        shapes = rng.uniform(0.2, 1.0, (3, 2, 2))
        r = noise_range.NoiseRange(shapes, -rng.uniform(0.02, 0.3, (3, 2)),
                                   rng.uniform(0.3, 1.5, (3, 2)))
        if len({p.x0.shape[0] for p in r.polygons}) > 1:
            break
    assert len({p.x0.shape[0] for p in r.polygons}) > 1
    seen = set()
    for k, poly in enumerate(r.polygons):
        a = rng.standard_normal((400, 2, 2))
        h = a @ np.swapaxes(a, 1, 2) + 0.3 * np.eye(2)
        g = 4 * rng.standard_normal((400, 2))
        x, face = noise_range._polygon_face(h, g, poly, r.n_edges)
        p, a1, kind = r.faces[0][k, face], r.faces[2][k, face], r.faces[4][k, face]
        scale = np.abs(x).max()
        vertex, edge = kind == 2, kind == 1
        np.testing.assert_allclose(x[vertex], p[vertex], atol=1e-9 * scale)
        on_line = np.einsum("wi,wi->w", a1[edge], x[edge] - p[edge])
        np.testing.assert_allclose(on_line, 0.0, atol=1e-9 * scale)
        assert np.all(kind >= 0)
        seen |= set(kind.tolist())
    assert {0, 1, 2} <= seen
