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
is guessed from the free minimum (each channel's most violated edge);
walkers the guess does not settle go on by a primal active-set method from
a sweep of block coordinate descent (:meth:`NoiseRange._descent`), which
adds or releases one line a step and ends in a few steps (at most 10 on
2776 walkers of a fit whose gains sat at the prior's bound, where block
coordinate descent zigzags between strongly coupled channels and after 50
sweeps is still short of the minimum), its work bounded by
:data:`ACTIVE_SET_STEPS`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Steps of the bounded profile's active-set method (:meth:`NoiseRange._descent`),
#: at most: each adds or releases one line.
ACTIVE_SET_STEPS = 40
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
    line: np.ndarray       # (E,) the edge's line (its row of a)
    lo_line: np.ndarray    # (E,) the line ending the edge at lo (-1: none)
    hi_line: np.ndarray    # (E,) and at hi


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
    lo_line = np.where(np.isfinite(lo), np.argmax(lower, axis=0), -1)
    hi_line = np.where(np.isfinite(hi), np.argmin(upper, axis=0), -1)
    lo_a = np.where(np.isfinite(lo)[:, None], a[lo_line], 0.0)
    hi_a = np.where(np.isfinite(hi)[:, None], a[hi_line], 0.0)
    tol = 1e-12 * (np.abs(b).max() + 1e-300)
    usable = (lo <= hi) & np.all(crossing | (room >= -tol), axis=0)
    k = usable if usable.any() else np.ones_like(usable)
    return Polygon(a, b, x0[k], v[k], lo[k], hi[k], usable[k], a[k], lo_a[k], hi_a[k],
                   np.flatnonzero(k), lo_line[k], hi_line[k])


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
        self._moves = _move_table(self.polygons, n)

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
        c, dual, kind, scale = self._face_solution(h, grad, faces)
        ok = np.all(kind >= 0, axis=1) & np.all(dual >= -scale[:, None, None], axis=(1, 2))
        return c, ok & self._feasible(c)

    def _face_solution(self, h, grad, faces):
        """:meth:`face_minimum`'s point, the multipliers of each channel's
        active lines (W, n_r, 2: its edge's line, then the other line of a
        vertex; 0 where none), the faces' kinds (W, n_r) and the multipliers'
        tolerance (W,)."""
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
        return c.reshape(nw, nr, 2), dual, kind, scale

    def _descent(self, h, grad):
        """A primal active-set method over the product of the polygons, from
        one sweep of block coordinate descent from zero noise (a feasible
        point and its faces): each step solves the current faces exactly
        (:meth:`_face_solution`); a solution outside the polygons is
        approached as far as the first line it crosses, which joins the
        faces; a solution inside with a negative multiplier releases that
        line; one inside with none is the bounded minimum (the
        Karush-Kuhn-Tucker conditions). The objective never rises, so after
        at most :data:`ACTIVE_SET_STEPS` steps each walker has a feasible
        point at least as good as the sweep's, the exact minimum once its
        faces settle."""
        nw, nr = grad.shape[0], len(self.polygons)
        c, faces = _sweep(h, grad, np.zeros((nw, nr, 2)), self.polygons, self.n_edges)
        todo = np.arange(nw)
        for _ in range(ACTIVE_SET_STEPS):
            cs, dual, kind, scale = self._face_solution(h[todo], grad[todo], faces[todo])
            inside = self._feasible(cs) & np.all(kind >= 0, axis=1)
            worst = dual.reshape(len(todo), 2 * nr).argmin(axis=1)
            release = inside & (dual.reshape(len(todo), -1)[np.arange(len(todo)), worst]
                                < -scale)
            done = inside & ~release
            c[todo[inside]] = cs[inside]
            faces[todo[release]] = self._released(faces[todo[release]], worst[release])
            step = ~inside & np.all(kind >= 0, axis=1)
            if step.any():
                c[todo[step]], faces[todo[step]] = self._blocked(
                    c[todo[step]], cs[step], faces[todo[step]], kind[step])
            # walkers done, or whose faces have no move (a degenerate vertex), keep their point
            todo = todo[~done & (inside | step) & np.all(faces[todo] >= 0, axis=1)]
            if not todo.size:
                break
        return c

    def _released(self, faces, worst):
        """The faces (W, n_r) with one active line released: ``worst`` (W,)
        indexes channel ``worst // 2`` and its line ``worst % 2`` (the edge's
        own line, or the other line of a vertex)."""
        faces = faces.copy()
        rows, k, j = np.arange(len(worst)), worst // 2, worst % 2
        faces[rows, k] = self._moves["release"][k, faces[rows, k], j]
        return faces

    def _blocked(self, c, target, faces, kind):
        """From the feasible ``c`` towards ``target`` (each (W, n_r, 2)) as
        far as the polygons allow: the point reached and the faces with the
        first line met added (a free channel onto that line's edge, an edge
        onto its vertex at that end)."""
        d = target - c
        ad = np.einsum("wki,kli->wkl", d, self._a)                          # (W, nr, L)
        slack = np.maximum(self._b[None] - np.einsum("wki,kli->wkl", c, self._a), 0.0)
        tiny = 1e-12 * np.linalg.norm(d, axis=2)[..., None] * np.linalg.norm(self._a, axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(ad > tiny, slack / ad, np.inf)
        ratio[kind == 2] = np.inf                                           # a vertex stays
        w, kk = np.nonzero(kind == 1)                                       # an edge keeps its line
        ratio[w, kk, self._moves["line"][kk, faces[w, kk]]] = np.inf
        flat = ratio.reshape(len(c), -1)
        first = flat.argmin(axis=1)
        alpha = np.clip(flat[np.arange(len(c)), first], 0.0, 1.0)
        c = c + alpha[:, None, None] * d
        k, line = np.unravel_index(first, ratio.shape[1:])
        rows = np.arange(len(c))
        toward_hi = np.einsum("wi,wi->w", d[rows, k], self._moves["v"][k, faces[rows, k]]) > 0
        faces = faces.copy()
        faces[rows, k] = np.where(kind[rows, k] == 0, self._moves["onto"][k, line],
                                  self._moves["end"][k, faces[rows, k], toward_hi.astype(int)])
        return c, faces


def _move_table(polygons, n):
    """The face moves of :meth:`NoiseRange._descent`, per channel (n_r, ...):
    ``onto`` (L,) the edge face of each line (-1: the line is no edge),
    ``end`` (F, 2) an edge face's vertex at its lo and hi end, ``v`` (F, 2)
    an edge face's direction, ``line`` (F,) its line, ``release`` (F, 2) the face left when a
    vertex lets go of its edge's line (then on the other line's edge) or of
    the other line (on its edge), or an edge lets go of its line (free);
    faces numbered as :func:`_polygon_face`'s for ``n`` edges, -1 where
    there is none."""
    nr, f = len(polygons), 1 + 3 * n
    lines = max(p.a.shape[0] for p in polygons)
    onto = np.full((nr, lines), -1)
    end = np.full((nr, f, 2), -1)
    v = np.zeros((nr, f, 2))
    line = np.zeros((nr, f), int)
    release = np.full((nr, f, 2), -1)
    for k, p in enumerate(polygons):
        edge_of = np.full(p.a.shape[0], -1)
        edge_of[p.line] = np.arange(p.line.size)
        onto[k, :p.a.shape[0]] = np.where(edge_of >= 0, 1 + edge_of, -1)
        for e in range(p.line.size):
            end[k, 1 + e] = (1 + n + 2 * e, 2 + n + 2 * e)
            v[k, 1 + e], line[k, 1 + e] = p.v[e], p.line[e]
            release[k, 1 + e] = (0, 0)
            for i, other in enumerate((p.lo_line[e], p.hi_line[e])):
                back = edge_of[other] if other >= 0 else -1
                release[k, 1 + n + 2 * e + i] = (1 + back if back >= 0 else -1, 1 + e)
    return {"onto": onto, "end": end, "v": v, "line": line, "release": release}


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
