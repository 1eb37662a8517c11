"""Posterior sampling: a new emcee move or convergence rule goes here.

* :mod:`.mcmc` every chain is run here, by emcee, with its moves and its
               convergence rule
* :mod:`.independence` the kept chain's move: a t proposal drawn and
               evaluated in batches, whatever the walkers' positions
* :mod:`.display` what a running chain says: a bar on a terminal, lines in a log

May import :mod:`bayescal.core.posterior` (how convergence is told).

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "mcmc": ["default_walkers", "sample"],
})
