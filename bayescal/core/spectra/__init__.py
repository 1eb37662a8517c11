"""Spectra of the recordings.

* :mod:`.welch`     streamed Welch cross-spectra, per-band matrices
* :mod:`.segments`  detrended, windowed segments' spectra, a chunk at a time;
                    the Hann window
* :mod:`.coherence` Welch multiple coherence alone (the band choice's)
* :mod:`.dof`       degrees of freedom of Welch band averages
* :mod:`.bandfold`  per-time-block spectra folded into bands and nodes
* :mod:`.transients` Welch segments where one sensor records a transient the
                    other does not (left out of a fit)

Imports no other part of :mod:`bayescal.core`.

Its public names (``__all__``) are loaded on first use; outside the core,
import them from here, not from its modules.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "welch": ["CrossSpectra", "band_refusal", "band_taper", "cross_spectra", "deconvolve_runs", "default_nperseg",
              "make_bands"],
    "segments": ["hann", "remove_line"],
    "dof": ["band_dof"],
    "bandfold": ["fold"],
    "coherence": ["welch_multiple_coherence"],
    "transients": ["find", "summary"],
})
