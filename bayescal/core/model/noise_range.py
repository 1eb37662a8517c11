"""The reference's noise profiled within the range the spectra admit.

In mode ``estimate`` (:mod:`bayescal.core.model.refnoise`) the reference's
noise in band ``b`` on channel ``k`` is ``d_b,k = sum_j c_kj s_bkj``, two
coefficients per channel for the whole band, kept within ``lower_b,k <=
d_b,k <= upper_b,k`` (:func:`bayescal.core.model.refnoise.admissible_noise`).
For one channel these are the half-planes of a polygon in its two
coefficients; the profile minimises a convex quadratic ``c^T h c + 2 g^T c``
over the product of the channels' polygons, per walker.

The minimum lies on one face of that product: each channel's point free,
on an edge, or at a vertex. Holding the face's constraints as equalities
leaves a linear system; its solution is the bounded minimum exactly when it
is feasible and every active constraint's multiplier is non-negative (the
Karush-Kuhn-Tucker conditions, sufficient for a convex problem). The face
is guessed from the free minimum (each channel's most violated edge), then
from a sweep of block coordinate descent; walkers neither guess settles go
on by block coordinate descent to convergence (:class:`NoiseRange`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Sweeps over the reference channels of the bounded profile's block coordinate descent.
BOUNDED_SWEEPS = 50
#: Relative tolerance of the active constraints, feasibility and multipliers of a face.
ACTIVE_TOL = 1e-9


class Polygon(NamedTuple):
    """The polygon ``a x <= b`` and its edges (:func:`polygon_edges`)."""

    a: np.ndarray          # (L, 2) every line
    b: np.ndarray          # (L,)
    x0: np.ndarray         # (E, 2) a point on each edge's line
    v: np.ndarray          # (E, 2) its direction
    lo: np.ndarray         # (E,) the feasible range of t on x0 + t v
    hi: np.ndarray
    usable: np.ndarray     # (E,) whether the line touches the polygon
    edge_a: np.ndarray     # (E, 2) the edge's row of a
    lo_a: np.ndarray       # (E, 2) the row of a of the line ending the edge at lo (0: none)
    hi_a: np.ndarray       # (E, 2) and at hi


def polygon_edges(a, b):
    """The polygon ``a x <= b`` (``a`` (L, 2), ``b`` (L,)) as a
    :class:`Polygon`: for each line that touches it a point ``x0`` on it,
    its direction ``v``, the feasible range of ``t`` on ``x0 + t v``
    (``lo``, ``hi``) and the lines that end it there; the lines that miss
    the polygon are left out (all are kept, ``usable`` False, when none
    touches)."""
    norm2 = np.einsum("li,li->l", a, a)
    x0 = a * (b / norm2)[:, None]                                           # (L, 2) on line l
    v = np.stack([-a[:, 1], a[:, 0]], axis=1)                               # along line l
    av = a @ v.T                                                            # (M, L)
    room = b[:, None] - a @ x0.T                                            # (M, L)
    crossing = np.abs(av) > 1e-12 * norm2[:, None]          # not parallel (a line and itself are)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = room / av
    lower = np.where(crossing & (av < 0), bound, -np.inf)
    upper = np.where(crossing & (av > 0), bound, np.inf)
    lo, hi = lower.max(axis=0), upper.min(axis=0)                          # (L,)
    lo_a = np.where(np.isfinite(lo)[:, None], a[np.argmax(lower, axis=0)], 0.0)
    hi_a = np.where(np.isfinite(hi)[:, None], a[np.argmin(upper, axis=0)], 0.0)
    tol = 1e-12 * (np.abs(b).max() + 1e-300)
    usable = (lo <= hi) & np.all(crossing | (room >= -tol), axis=0)
    k = usable if usable.any() else np.ones_like(usable)
    return Polygon(a, b, x0[k], v[k], lo[k], hi[k], usable[k], a[k], lo_a[k], hi_a[k])


def polygon_minimum(h, g, poly):
    """``argmin x^T h x + 2 g^T x`` (``h`` positive definite) over a
    :class:`Polygon` (which holds 0; it may be unbounded), per walker: ``h``
    (W, 2, 2), ``g`` (W, 2). The minimum is the free one when feasible, else
    on an edge: each line is searched (the 1-D minimum clipped to the line's
    feasible segment) and the best point kept."""
    return _polygon_face(h, g, poly)[0]


def _polygon_face(h, g, poly, n=None):
    """:func:`polygon_minimum` and the face it lies on, (W,): 0 free, ``1 +
    e`` inside edge ``e``, ``1 + n + 2 e`` (``+ 1``) at its ``lo`` (``hi``)
    end, ``n`` the number of edges faces are counted for (None: the
    polygon's own)."""
    a, b, x0, v, lo, hi, usable = poly[:7]
    tol = 1e-12 * (np.abs(b).max() + 1e-300)
    free = -np.linalg.solve(h, g[..., None])[..., 0]                       # (W, 2)
    ok = np.all(free @ a.T <= b + tol, axis=1)
    hv, hx0 = h @ v.T, h @ x0.T                                             # (W, 2, L)
    curv = np.sum(v.T[None] * hv, axis=1)                                   # (W, L)
    slope = np.sum(v.T[None] * hx0, axis=1) + g @ v.T
    f0 = np.sum(x0.T[None] * hx0, axis=1) + 2 * (g @ x0.T)
    t = np.clip(-slope / curv, lo, hi)
    f = np.where(usable[None], f0 + 2 * t * slope + t * t * curv, np.inf)
    best = np.argmin(f, axis=1)
    rows = np.arange(h.shape[0])
    tb = t[rows, best]
    edge = x0[best] + tb[:, None] * v[best]
    n = x0.shape[0] if n is None else n
    face = np.where(tb == lo[best], 1 + n + 2 * best,
                    np.where(tb == hi[best], 2 + n + 2 * best, 1 + best))
    return np.where(ok[:, None], free, edge), np.where(ok, 0, face)


def _face_table(poly, n):
    """Every face of ``poly`` as the affine map ``x = p + Z y`` and its
    active lines: ``p`` (F, 2), ``Z`` (F, 2, 2), ``a1``, ``a2`` (F, 2),
    ``kind`` (F,) 0 free, 1 edge, 2 vertex, -1 none; faces numbered as
    :func:`_polygon_face`'s, for ``n`` edges (at least the polygon's)."""
    f = 1 + 3 * n
    p, z = np.zeros((f, 2)), np.zeros((f, 2, 2))
    a1, a2, kind = np.zeros((f, 2)), np.zeros((f, 2)), np.full(f, -1)
    z[0], kind[0] = np.eye(2), 0
    for e in range(poly.x0.shape[0]):
        p[1 + e], z[1 + e, :, 0], a1[1 + e], kind[1 + e] = poly.x0[e], poly.v[e], poly.edge_a[e], 1
        for end, (t, other) in enumerate(((poly.lo[e], poly.lo_a[e]), (poly.hi[e], poly.hi_a[e]))):
            i = 1 + n + 2 * e + end
            pair = np.stack([poly.edge_a[e], other], axis=1)
            if np.isfinite(t) and abs(np.linalg.det(pair)) > 1e-12 * (poly.edge_a[e] @ poly.edge_a[e]):
                p[i], a1[i], a2[i], kind[i] = poly.x0[e] + t * poly.v[e], poly.edge_a[e], other, 2
    return p, z, a1, a2, kind


class NoiseRange:
    """The range ``lower <= d_b,k <= upper`` (each (B, n_r), ``lower <= 0 <=
    upper``) of the reference's noise ``d_b,k = sum_j c_kj shapes_bkj``
    (``shapes`` (B, n_r, 2)) as one polygon of the two coefficients per
    reference channel, and the profile's minimum within it
    (:meth:`minimum`); built once for every walker and call."""

    def __init__(self, shapes, lower, upper):
        self.lower, self.upper = lower, upper
        self.polygons = [polygon_edges(np.concatenate([-shapes[:, k, :], shapes[:, k, :]]),
                                       np.concatenate([-lower[:, k], upper[:, k]]))
                         for k in range(shapes.shape[1])]
        n = self.n_edges = max(p.x0.shape[0] for p in self.polygons)
        self.faces = [np.stack(t) for t in zip(*(_face_table(p, n) for p in self.polygons))]
        # every channel's lines (n_r, L, 2) and (n_r, L), the right-hand sides
        # with their tolerance; its edges' unit normals and offsets, (n_r, n, ...)
        self._a = np.stack([p.a for p in self.polygons])
        self._b = np.stack([p.b + ACTIVE_TOL * np.abs(p.b).max() for p in self.polygons])
        self._normal = np.zeros((len(self.polygons), n, 2))
        self._offset = np.full((len(self.polygons), n), np.inf)
        for k, p in enumerate(self.polygons):
            norm = np.sqrt(np.einsum("ei,ei->e", p.edge_a, p.edge_a))[:, None]
            self._normal[k, :len(norm)] = p.edge_a / norm
            self._offset[k, :len(norm)] = np.einsum("ei,ei->e", p.edge_a / norm, p.x0)

    def minimum(self, h, grad, free):
        """Minimise ``c^T h c + 2 grad^T c`` (``h`` (W, 2 n_r, 2 n_r)
        positive definite, ``grad`` (W, 2 n_r)) with every channel's noise in
        the range; ``free`` (W, n_r, 2) the unbounded minimum. Returns the
        coefficients, (W, n_r, 2) (module docstring)."""
        nw, nr = free.shape[:2]
        if nr == 1:               # one block: its polygon's minimum is the answer
            return polygon_minimum(h, grad, self.polygons[0])[:, None]
        c, ok = self.face_minimum(h, grad, self._guess(free))
        if not ok.all():
            c[~ok] = self._descent(h[~ok], grad[~ok])
        return c

    def _feasible(self, c):
        """(W,) whether every channel of ``c`` (W, n_r, 2) lies in its
        polygon (within :data:`ACTIVE_TOL`)."""
        return np.all(np.einsum("wki,kli->wkl", c, self._a) <= self._b, axis=(1, 2))

    def _guess(self, free):
        """(W, n_r) a face per channel: free where ``free`` is feasible,
        else the edge ``free`` lies furthest outside."""
        excess = np.einsum("wki,kei->wke", free, self._normal) - self._offset
        inside = np.all(np.einsum("wki,kli->wkl", free, self._a) <= self._b, axis=2)
        return np.where(inside, 0, 1 + np.argmax(excess, axis=2))

    def face_minimum(self, h, grad, faces):
        """The exact minimum with each channel held on its face (``faces``
        (W, n_r), numbered as :func:`_polygon_face`'s) and whether it is the
        bounded minimum (feasible, every active multiplier non-negative):
        ``(c, ok)``, (W, n_r, 2) and (W,)."""
        nw, nr = faces.shape
        k = np.arange(nr)
        p, z, a1, a2, kind = (t[k, faces] for t in self.faces)
        zf = np.zeros((nw, nr, 2, nr, 2))
        zf[:, k, :, k, :] = np.swapaxes(z, 0, 1)
        zf = zf.reshape(nw, 2 * nr, 2 * nr)
        unused = ~np.any(zf, axis=1)                                        # (W, 2 nr)
        pf = p.reshape(nw, 2 * nr)
        red = np.swapaxes(zf, 1, 2) @ h @ zf + unused[:, :, None] * np.eye(2 * nr)
        y = np.linalg.solve(red, -(np.swapaxes(zf, 1, 2) @ (h @ pf[..., None]
                                                             + grad[..., None])))
        c = pf + (zf @ y)[..., 0]
        hc = (h @ c[..., None])[..., 0]
        g = (hc + grad).reshape(nw, nr, 2)             # at the minimum: -(l1 a1 + l2 a2)
        scale = ACTIVE_TOL * (np.abs(hc).max(axis=1) + np.abs(grad).max(axis=1) + 1e-300)
        second = np.where((kind == 2)[..., None], a2, np.stack([-a1[..., 1], a1[..., 0]], -1))
        pair = np.where((kind > 0)[..., None, None], np.stack([a1, second], axis=-1), np.eye(2))
        lam = np.linalg.solve(pair, -g[..., None])[..., 0] * np.sqrt(
            np.sum(pair ** 2, axis=-2))                      # (W, nr, 2) in gradient units
        dual = np.where(kind[..., None] == 2, lam, np.where(kind[..., None] == 1,
                                                             lam * [1.0, 0.0], 0.0))
        ok = np.all(kind >= 0, axis=1) & np.all(dual >= -scale[:, None, None], axis=(1, 2))
        c = c.reshape(nw, nr, 2)
        return c, ok & self._feasible(c)

    def _descent(self, h, grad):
        """Block coordinate descent from zero noise (feasible): each channel's
        two coefficients minimised exactly in turn, the others held; after
        each sweep the walkers' faces are solved exactly
        (:meth:`face_minimum`) and those settled leave."""
        nw, nr = grad.shape[0], len(self.polygons)
        c, todo = np.zeros((nw, nr, 2)), np.arange(nw)
        for sweep in range(BOUNDED_SWEEPS):
            before = c[todo]
            cs, faces = _sweep(h[todo], grad[todo], before.copy(), self.polygons, self.n_edges)
            c[todo] = cs
            exact, ok = self.face_minimum(h[todo], grad[todo], faces)
            c[todo[ok]] = exact[ok]
            todo, cs, before = todo[~ok], cs[~ok], before[~ok]
            if not todo.size:
                break
            scale = np.maximum(np.abs(cs).max(axis=(1, 2)), 1e-300)
            if np.all(np.abs(cs - before).max(axis=(1, 2)) <= 1e-10 * scale):
                break
        return c


def _sweep(h, grad, c, polygons, n):
    """One sweep of block coordinate descent (``c`` updated in place) and
    each channel's face at its end, (W, n_r)."""
    nw, nr, _ = c.shape
    hb = h.reshape(nw, nr, 2, nr, 2)
    faces = np.zeros((nw, nr), int)
    for k in range(nr):
        g = grad.reshape(nw, nr, 2)[:, k] + np.einsum("wilj,wlj->wi", hb[:, k], c) \
            - np.einsum("wij,wj->wi", hb[:, k, :, k], c[:, k])
        c[:, k], faces[:, k] = _polygon_face(hb[:, k, :, k], g, polygons[k], n)
    return c, faces
