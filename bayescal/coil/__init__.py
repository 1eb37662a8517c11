"""Calibration from coil signals.

Holds the symmetric triaxial geometry (:mod:`.triaxial`), one calibration
run read and turned into spectra (:mod:`.runs`), the likelihood and fit of
one element from one run (:mod:`.element`) with the variance of its band
residuals computed from the recorded input (:mod:`.bandvariance`), the coil-by-coil calibration
of UVW sensors with the derived XYZ responses (:mod:`.uvw`), and the
calibration of one ordinary channel: response parametrisation with the
high-frequency poles (:mod:`.hf`), random runs (:mod:`.random`), the
time-domain likelihood with AR noise (:mod:`.timedomain`) of step runs
(:mod:`.step`) and sine runs (:mod:`.sine`) driven by their idealised input
(:mod:`.drive`), the result and ``cal.json``
(:mod:`.result`), corrected StationXML (:mod:`.calxml`); the posterior every
coil model shares (:mod:`.bounded`).

May import :mod:`bayescal.core` and :mod:`bayescal.io`; nothing above them
(no reports, no command line).

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "element": ["ElementFit", "RunModel", "fit_run", "least_squares_run", "run_spectra"],
    "hf": ["PZSpec", "hf_items"],
    "random": ["PZModel", "default_cal_band", "fit_random"],
    "sine": ["SineFit", "fit_sine", "sine_frequency"],
    "step": ["StepModel", "fit_step", "least_squares_step"],
    "result": ["CalFit"],
    "runs": ["CalRun", "default_band", "read_run"],
    "triaxial": ["ELEMENTS", "PARAMS", "SENSORS", "STS2_UVW", "TRILLIUM_UVW", "XYZ",
                 "cross_talk", "load_matrix", "output_axis", "response_matrix",
                 "seed_xyz_diagonal", "sensor_matrix", "uvw_to_xyz", "xyz_to_uvw"],
    "uvw": ["AGREEMENT_Z", "SCHEMA", "UVWResult", "agreement", "calibrate_uvw", "derive_xyz",
            "element_ratios", "equivalent_two_pole"],
    "bounded": ["BoundedPosterior"],
    "calxml": ["corrected_cal_inventory", "write_corrected_cal"],
    "timedomain": ["Predictor", "ar_fit", "coil_transfer", "padding"],
})
