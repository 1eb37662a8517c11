"""How a chain's convergence and its sampler are told to a user: the one
NOT CONVERGED line and the sampler in words.

Light on purpose (no emcee, no model): the console, the reports and a
stored result's readers use it without importing the sampling code
(:mod:`bayescal.core.sampling.mcmc`)."""
from __future__ import annotations

from ...result import Convergence


def not_converged_line(convergence, what="the sampler", option="--max-steps"):
    """The one line said for a chain that stopped at ``max_steps`` (None when
    it converged). ``convergence``: a result's ``convergence`` entry
    (``n_steps``, ``ess_min``, ``rhat_max``, ``converged``); ``option``: how
    the reader raises the step limit (the command's option, or the keyword)."""
    if convergence.get("converged", True):
        return None
    return (f"NOT CONVERGED: {what} stopped at {convergence['n_steps']} steps before meeting "
            f"its convergence rule ({Convergence.figures(convergence)}): the intervals are "
            f"provisional; rerun with a larger {option}")


def describe_sampler(record):
    """One line naming what sampled a posterior, from a result's
    ``meta.sampler`` (:attr:`bayescal.core.sampling.mcmc.Chain.sampler`): the library
    and version, the walkers, and each phase's moves (weights), steps and
    acceptance. None when there is no record."""
    if not record:
        return None
    if not record.get("library"):
        return record.get("approximation")
    phases = []
    for p in record.get("phases", []):
        moves = " + ".join(f"{m['move'].split(' (')[0]} {m['weight']:g}" for m in p["moves"])
        phases.append(f"{moves}: {p['steps']} steps, acceptance {p['acceptance']:.2f}")
    return (f"{record['library']} {record['version']}, {record['walkers']} walkers; "
            + "; then ".join(phases))
