"""Spectra of the recordings.

* :mod:`.welch`     streamed Welch cross-spectra, per-band matrices, the Hann
                    window
* :mod:`.coherence` Welch multiple coherence alone (the band choice's)
* :mod:`.dof`       degrees of freedom of Welch band averages
* :mod:`.bandfold`  per-time-block spectra folded into bands and nodes
* :mod:`.transients` Welch segments where one sensor records a transient the
                    other does not (left out of a fit)

Imports no other part of :mod:`bayescal.core`.
"""
