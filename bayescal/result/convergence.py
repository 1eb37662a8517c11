"""A chain's convergence figures and the ``convergence`` entry of a result
file, in one small container."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Convergence:
    """Every sampled parameter's integrated autocorrelation time ``tau``,
    effective sample size ``ess`` and split R-hat ``rhat`` (arrays, one per
    parameter), the run's ``acceptance``, ``n_steps``, ``n_walkers`` and
    ``burn`` (steps discarded), and whether the convergence rule held."""

    tau: np.ndarray
    ess: np.ndarray
    rhat: np.ndarray
    acceptance: float
    n_steps: int
    n_walkers: int
    burn: int
    converged: bool

    @classmethod
    def from_dict(cls, d):
        """From :meth:`to_dict`'s dict, as stored in ``samples.npz`` (a
        Convergence is returned as it is)."""
        if isinstance(d, cls):
            return d
        return cls(tau=np.asarray(d["tau"], float), ess=np.asarray(d["ess"], float),
                   rhat=np.asarray(d["rhat"], float), acceptance=d["acceptance"],
                   n_steps=d["n_steps"], n_walkers=d["n_walkers"], burn=d.get("burn", 0),
                   converged=d["converged"])

    def to_dict(self):
        """Every figure, as stored in ``samples.npz``."""
        return {"tau": self.tau, "ess": self.ess, "rhat": self.rhat,
                "acceptance": self.acceptance, "n_steps": self.n_steps,
                "n_walkers": self.n_walkers, "burn": self.burn, "converged": self.converged}

    @property
    def ess_min(self):
        """The smallest effective sample size over the parameters."""
        return float(np.min(self.ess))

    @staticmethod
    def figures(summary):
        """``"ESS min 812, R-hat max 1.0031"``: the slowest parameter's figures
        of a ``convergence`` entry (:meth:`summary`'s dict, as ``result.json``
        and ``cal.json`` hold it), as the console and every report print them."""
        return f"ESS min {summary['ess_min']:.0f}, R-hat max {summary['rhat_max']:.4f}"

    def summary(self, names=None):
        """The ``convergence`` entry of ``result.json``: the slowest
        parameter's figures, the run's size, whether the rule held and, with
        the parameters' ``names``, each one's figures."""
        out = {"ess_min": self.ess_min, "tau_max": float(np.max(self.tau)),
               "rhat_max": float(np.max(self.rhat)), "n_steps": int(self.n_steps),
               "n_walkers": int(self.n_walkers), "acceptance": float(self.acceptance),
               "converged": bool(self.converged)}
        if names is not None:
            out["per_parameter"] = {n: {"tau": float(t), "ess": float(e), "rhat": float(r)}
                                    for n, t, e, r in zip(names, self.tau, self.ess, self.rhat)}
        return out
