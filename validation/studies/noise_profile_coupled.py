"""The bounded noise profile on strongly coupled channels: block coordinate
descent against the active-set method of
:meth:`bayescal.core.model.noise_range.NoiseRange._descent`.

The inputs are those of a real fit: ``day_1hz_no_digitizer`` of
``benchmarks/awkward_inputs.py`` (its gains far outside the prior), with the
refusal of :func:`bayescal.core.checks.gain_bounds.off_scale` bypassed so
that the least squares, the mode search and the sampler run. Every call of
the profile whose face guess leaves walkers to the fallback, and for which
block coordinate descent (below) takes at least ``--hard`` sweeps, is
recorded (the matrix ``h`` and gradient of each such walker) until
``--calls`` calls are held (the fit's calls to the fallback are counted).
Each walker's minimum is then computed by

* block coordinate descent from zero noise, a sweep at a time, each sweep
  followed by the exact solution on the faces it lands on, until those are
  the bounded minimum or ``--sweeps`` sweeps are spent;
* the active-set method (the package's fallback);

and, on ``--enumerate`` of them (seeded choice), by enumerating every
product of faces. Written: the sweeps descent needed per call, the share of
calls that spent them all, each method's CPU time, and each method's
largest relative excess of the objective over the enumerated minimum.

    python validation/studies/noise_profile_coupled.py [--calls 300] [--hard 20]
        [--sweeps 50] [--enumerate 60] [--out validation/results/speed/noise_profile_coupled.json]
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bayescal.core.model import noise_range  # noqa: E402


class Enough(Exception):
    """Raised inside the fit once enough calls are recorded."""


def capture(n_calls, hard, sweeps):
    """``(range, h, grad, calls)`` of the fallback walkers of the first
    ``n_calls`` profile calls on which descent takes at least ``hard``
    sweeps, from the fit of ``day_1hz_no_digitizer``; ``calls`` the calls
    to the fallback made meanwhile."""
    import awkward_inputs
    from bayescal.core.checks import gain_bounds
    from bayescal.cli import main

    held = {"range": None, "h": [], "g": [], "calls": 0}
    active_set = noise_range.NoiseRange._descent

    def record(self, h, grad):
        held["range"], held["calls"] = self, held["calls"] + 1
        if descent(self, h, grad, sweeps)[1] >= hard:
            held["h"].append(h.copy())
            held["g"].append(grad.copy())
        if len(held["h"]) >= n_calls:
            raise Enough
        return active_set(self, h, grad)

    noise_range.NoiseRange._descent = record
    gain_bounds.off_scale = lambda model, theta: {}
    with tempfile.TemporaryDirectory() as folder:
        argv = awkward_inputs.prepare(folder, ["day_1hz_no_digitizer"])["day_1hz_no_digitizer"]
        try:
            main(["fit", *argv, "--out", os.path.join(folder, "out"), "--no-report", "--quiet"])
        except Enough:
            pass
    noise_range.NoiseRange._descent = active_set
    return held["range"], held["h"], held["g"], held["calls"]


def descent(r, h, grad, sweeps):
    """Block coordinate descent as described in the module docstring:
    ``(c, sweeps used)``."""
    nw, nr = grad.shape[0], len(r.polygons)
    c, todo = np.zeros((nw, nr, 2)), np.arange(nw)
    for used in range(1, sweeps + 1):
        before = c[todo]
        cs, faces = noise_range._sweep(h[todo], grad[todo], before.copy(), r.polygons, r.n_edges)
        c[todo] = cs
        exact, ok = r.face_minimum(h[todo], grad[todo], faces)
        c[todo[ok]] = exact[ok]
        todo, cs, before = todo[~ok], cs[~ok], before[~ok]
        if not todo.size:
            return c, used
        scale = np.maximum(np.abs(cs).max(axis=(1, 2)), 1e-300)
        if np.all(np.abs(cs - before).max(axis=(1, 2)) <= 1e-10 * scale):
            return c, used
    return c, sweeps


def enumerated(h, g, polygons):
    """The minimum over every product of faces (each channel free, on an
    edge's line, or at a pair of lines' crossing), feasible ones only."""
    def faces(p):
        out = [(np.zeros(2), np.eye(2))]
        out += [(x0, v[:, None]) for x0, v in zip(p.x0, p.v)]
        for i, j in itertools.combinations(range(len(p.b)), 2):
            m = p.a[[i, j]]
            if abs(np.linalg.det(m)) > 1e-12:
                out.append((np.linalg.solve(m, p.b[[i, j]]), np.zeros((2, 0))))
        return out
    best, arg = np.inf, None
    for combo in itertools.product(*(faces(p) for p in polygons)):
        p0 = np.concatenate([f[0] for f in combo])
        z = np.zeros((p0.size, sum(f[1].shape[1] for f in combo)))
        col = 0
        for k, f in enumerate(combo):
            z[2 * k:2 * k + 2, col:col + f[1].shape[1]] = f[1]
            col += f[1].shape[1]
        y = (np.linalg.lstsq(z.T @ h @ z, -z.T @ (h @ p0 + g), rcond=None)[0]
             if z.shape[1] else np.zeros(0))
        c = p0 + z @ y
        if all(np.all(p.a @ c[2 * k:2 * k + 2] <= p.b + 1e-9 * np.abs(p.b).max())
               for k, p in enumerate(polygons)):
            f = c @ h @ c + 2 * g @ c
            if f < best:
                best, arg = f, c
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=300)
    ap.add_argument("--hard", type=int, default=20)
    ap.add_argument("--sweeps", type=int, default=50)
    ap.add_argument("--enumerate", type=int, default=60)
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "speed"
                                         / "noise_profile_coupled.json"))
    a = ap.parse_args(argv)
    r, hs, gs, calls = capture(a.calls, a.hard, a.sweeps)
    if not hs:
        raise SystemExit(f"no call of {calls} took {a.hard} sweeps of descent")
    used, t_descent, t_active = [], 0.0, 0.0
    c_descent, c_active = [], []
    for h, g in zip(hs, gs):
        t = time.process_time()
        c, n = descent(r, h, g, a.sweeps)
        t_descent += time.process_time() - t
        used.append(n)
        c_descent.append(c)
        t = time.process_time()
        c_active.append(r._descent(h, g))
        t_active += time.process_time() - t
    h, g = np.concatenate(hs), np.concatenate(gs)

    def objective(c):
        c = np.concatenate(c).reshape(len(g), -1)
        return np.einsum("wi,wij,wj->w", c, h, c) + 2 * np.einsum("wi,wi->w", g, c)
    f_descent, f_active = objective(c_descent), objective(c_active)
    pick = np.random.default_rng(44).choice(len(g), min(a.enumerate, len(g)), replace=False)
    f_enum = np.array([enumerated(h[w], g[w], r.polygons) for w in pick])
    excess = {name: float(np.max((f[pick] - f_enum) / np.abs(f_enum)))
              for name, f in (("descent", f_descent), ("active_set", f_active))}
    used = np.array(used)
    result = {"command": "python validation/studies/noise_profile_coupled.py "
                         + " ".join(argv if argv is not None else sys.argv[1:]),
              "fallback_calls": calls, "calls_held": len(hs), "hard_sweeps": a.hard,
              "walkers": int(len(g)),
              "condition_number_max": float(np.linalg.cond(h).max()),
              "descent_sweeps": {"median": float(np.median(used)), "max": int(used.max()),
                                 "share_at_limit": float(np.mean(used == a.sweeps)),
                                 "limit": a.sweeps},
              "cpu_s": {"descent": t_descent, "active_set": t_active},
              "enumerated_walkers": int(len(pick)),
              "max_relative_excess_over_enumerated_minimum": excess,
              "active_set_lower_than_descent_share": float(np.mean(
                  f_descent - f_active > 1e-9 * np.abs(f_descent)))}
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
