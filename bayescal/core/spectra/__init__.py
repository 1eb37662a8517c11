"""Spectra of the recordings.

* :mod:`.welch`     streamed Welch cross-spectra, per-band matrices, the Hann
                    window
* :mod:`.coherence` Welch multiple coherence alone (the band choice's)
* :mod:`.dof`       degrees of freedom of Welch band averages
* :mod:`.bandfold`  per-time-block spectra folded into bands and nodes

Imports no other part of :mod:`bayescal.core`.
"""
