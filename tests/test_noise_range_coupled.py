"""The bounded profile of the reference's noise when its channels are
strongly coupled (:meth:`bayescal.core.model.noise_range.NoiseRange.minimum`):
the case of a fit whose gains sit at the prior's bound, where block
coordinate descent zigzags between the channels and stops short of the
minimum. The active-set method ends at the minimum found by enumerating
every product of faces, within :data:`~bayescal.core.model.noise_range.ACTIVE_SET_STEPS`
steps."""
from __future__ import annotations

import numpy as np

from bayescal.core.model import noise_range
from test_refnoise_bounds import _enumerated_minimum


def test_coupled_channels_end_at_the_enumerated_minimum(monkeypatch):
    rng = np.random.default_rng(2024)
    nb, nr, nw = 3, 3, 40
    shapes = rng.uniform(0.2, 1.0, (nb, nr, 2))
    r = noise_range.NoiseRange(shapes, -rng.uniform(0.02, 0.3, (nb, nr)),
                               rng.uniform(0.3, 1.5, (nb, nr)))
    # two stiff directions mixing every channel's coefficients, the rest a thousand to a
    # million times softer
    u = rng.standard_normal((nw, 2 * nr, 2))
    a = rng.standard_normal((nw, 2 * nr, 2 * nr))
    h = u @ np.swapaxes(u, 1, 2) + 1e-3 * a @ np.swapaxes(a, 1, 2) + 1e-6 * np.eye(2 * nr)
    grad = rng.standard_normal((nw, 2 * nr)) * rng.uniform(0.1, 2.0, (nw, 1))
    free = -np.linalg.solve(h, grad[..., None])[..., 0].reshape(nw, nr, 2)
    c = r.minimum(h, grad, free)
    # the guess settles few walkers: the active-set method takes the rest
    assert np.mean(r.face_minimum(h, grad, r._guess(free))[1]) < 0.2
    for w in range(nw):
        ref = _enumerated_minimum(h[w], grad[w], r.polygons)
        np.testing.assert_allclose(c[w].ravel(), ref, rtol=1e-7, atol=1e-9 * np.abs(ref).max(),
                                   err_msg=f"walker {w}")
    # every walker settled before the step limit: the last step's walkers were all done
    steps = []
    solve = noise_range.NoiseRange._face_solution

    def counted(self, h_, g_, faces):
        steps.append(len(faces))
        return solve(self, h_, g_, faces)
    monkeypatch.setattr(noise_range.NoiseRange, "_face_solution", counted)
    r.minimum(h, grad, free)
    assert len(steps) - 1 < noise_range.ACTIVE_SET_STEPS
