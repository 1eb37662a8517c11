"""Synthetic recordings with known truth.

* :mod:`.pair`      a co-located pair (with concealed effects on request)
* :mod:`.ground`    a second family of ground spectra for the pair
* :mod:`.coil`      coil calibration runs of a triaxial sensor
* :mod:`.cal`       a random, step or sine coil calibration run of one channel
* :mod:`.network`   an SDS archive of pairs over stations and days
* :mod:`.selfnoise` three co-located sensors with known self-noise
* :mod:`.coverage`  the uncertainty check: simulate, fit, count the truths inside
* :mod:`.harness`   seeded draws the validation studies and the tests share

The generators import only :mod:`bayescal.core` (:mod:`.selfnoise` builds
its StationXML with :func:`bayescal.io.read.paz_inventory`); :mod:`.coverage` also runs
:mod:`bayescal.pair` on what it simulates, and :mod:`.harness` prepares
a pair's cross-spectra with :func:`bayescal.pair.prepare` (neither is imported here).

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "selfnoise": ["DIGITIZER", "STS1", "T240", "estimate_and_truth", "simulate_colocated"],
    "pair": ["DIGITIZER_GAIN", "NORM_FREQ", "self_noise_psd", "simulate_pair",
             "velocity_response"],
    "cal": ["HF_NOMINAL", "LP_NOMINAL", "simulate_random_cal", "simulate_sine_cal",
            "simulate_step_cal"],
    "ground": ["SteepMicroseism", "ground_family"],
    "harness": ["KINDS", "REGIMES", "band_noise_truth", "coherences", "concealed_pair",
                "draw_truth", "tilt_pair_spectra"],
    "coverage": ["binomial_band", "coverage_checks", "draw_case", "run_case", "summarise"],
    "coil": ["STS2_NOMINAL", "simulate_calibration"],
    "network": ["sds_path", "write_network"],
})
