"""The inference core: plain numpy functions and small dataclasses, no file I/O.

Modules, in the order data flows through them:

* :mod:`.geometry`   angles <-> unit vectors (NED), SEED conventions, manifolds
* :mod:`.response`   parametric two-pole responses, evaluation of ObsPy responses
* :mod:`.pendulum`   the pendulum's sampling coordinates, its prior, what the data fix
* :mod:`.spectra`    streamed Welch cross-spectra and per-band matrices
* :mod:`.coherence`  Welch multiple coherence alone (the band choice's)
* :mod:`.transients` segments where one sensor records a transient the other does not
* :mod:`.bandfold`   per-time-block spectra folded into bands and nodes
* :mod:`.jacobian`   batched forward-difference Jacobian for least squares
* :mod:`.likelihood` the Frobenius residual, its noise model, vectorised log-prob
* :mod:`.plugin`     band weights for the plug-in noise model's own sampling error
* :mod:`.sampler`    closed-form start, least squares, emcee, convergence control
* :mod:`.reference_tolerance` the reference's metadata tolerance in the SUT's response
* :mod:`.posterior`  samples, summaries, result.json / samples.npz
* :mod:`.selfnoise`  self-noise of three or more co-located sensors (Sleeman),
                     its Wishart-bootstrap interval

May import only numpy, scipy, emcee, ObsPy's response evaluation and
:mod:`bayescal.version`; never another bayescal subpackage.
"""
