"""Posterior sampling: a new emcee move or convergence rule goes here.

* :mod:`.mcmc`        every chain is run here, by emcee, with its moves
* :mod:`.convergence` the convergence warning and how a chain is told to a user

Imports no other part of :mod:`bayescal.core`.
"""
