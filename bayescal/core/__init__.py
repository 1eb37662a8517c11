"""The inference core: plain numpy functions and small dataclasses, no file I/O.

Grouped by idea, one subpackage each; in the order data flows through them:

* :mod:`.orientation` channel orientations: angles, unit vectors, tilt regions
* :mod:`.response`    instrument responses: the two-pole family, ObsPy
                      responses evaluated, the pendulum's coordinates and prior
* :mod:`.spectra`     Welch cross-spectra, coherence, bands
* :mod:`.model`       the likelihood and every term of it: noise models,
                      errors in variables, band weights, its Jacobian
* :mod:`.checks`      does the model fit, can the data tell it: adequacy,
                      separation, record length
* :mod:`.sampling`    emcee, its moves and its convergence rule
* :mod:`.posterior`   posterior samples and their summaries
* :mod:`.fit`         the whole fit: start, least squares, modes, held
                      parameters, sampling, the posterior
* :mod:`.selfnoise`   self-noise of co-located sensors
* :mod:`.priors`      the priors of every fit (:class:`~bayescal.core.priors.Priors`)
* :mod:`.threads`     the BLAS thread limit every group's small products run under
* :mod:`.budget`      work budgets: a stage's work counted in model evaluations,
                      with a wall-clock limit only as a safety net
* :mod:`.progress`    where a fit's time goes: each stage's line (or bar) on stderr

Each subpackage's docstring names its modules and the subpackages it may
import. The core as a whole may import only numpy, scipy, emcee,
threadpoolctl, ObsPy's response evaluation, :mod:`bayescal.version`,
:mod:`bayescal.errors` and :mod:`lazy_loader`; never another bayescal subpackage.

Outside the core, a name of the core is imported from the face of its group
(``from bayescal.core.spectra import cross_spectra``), or from this face for
the core's top-level modules (``from bayescal.core import Priors``); never
from a group's modules (the layout test rejects ``bayescal.core.<group>.<module>``
imports from outside the core). Inside the core, a group imports the modules
of the groups it may import. Every face lists its public names in
``__all__`` and loads each on first use (:func:`lazy_loader.attach`), so
importing a face costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "budget": ["Budget"],
    "priors": ["Priors"],
    "threads": ["single_threaded_blas"],
})
