"""Posterior sampling: a new emcee move or convergence rule goes here.

* :mod:`.mcmc` every chain is run here, by emcee, with its moves and its
               convergence rule

May import :mod:`bayescal.core.posterior` (how convergence is told).
"""
