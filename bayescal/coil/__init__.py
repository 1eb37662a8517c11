"""Calibration from coil signals.

Holds the symmetric triaxial geometry (:mod:`.triaxial`), one calibration
run read and turned into spectra (:mod:`.runs`), the likelihood and fit of
one element from one run (:mod:`.element`), the coil-by-coil calibration
of UVW sensors with the derived XYZ responses (:mod:`.uvw`), and the
calibration of one ordinary channel: response parametrisation with the
high-frequency poles (:mod:`.hf`), random runs (:mod:`.random`), the
time-domain likelihood with AR noise (:mod:`.timedomain`) of step runs
(:mod:`.step`) and sine runs (:mod:`.sine`), the result and ``cal.json``
(:mod:`.result`), corrected StationXML (:mod:`.calxml`); the posterior every
coil model shares (:mod:`.bounded`).

May import :mod:`bayescal.core` and :mod:`bayescal.io`; nothing above them
(no reports, no command line).
"""
from .element import ElementFit, RunModel, fit_run, least_squares_run, run_spectra
from .hf import PZSpec, hf_items
from .random import fit_random
from .sine import SineFit, fit_sine
from .step import fit_step
from .result import CalFit
from .runs import CalRun, default_band, read_run
from .triaxial import (ELEMENTS, PARAMS, SENSORS, XYZ, cross_talk, load_matrix, output_axis,
                       response_matrix, seed_xyz_diagonal, sensor_matrix, uvw_to_xyz, xyz_to_uvw)
from .uvw import (AGREEMENT_Z, SCHEMA, UVWResult, agreement, calibrate_uvw, derive_xyz,
                  element_ratios, equivalent_two_pole)
from ..core.orientation.geometry import STS2_UVW, TRILLIUM_UVW

__all__ = ["PZSpec", "hf_items", "fit_random", "fit_step", "fit_sine", "SineFit", "CalFit", "default_band", "ElementFit", "RunModel", "fit_run", "least_squares_run", "CalRun", "read_run",
           "run_spectra", "ELEMENTS", "PARAMS", "SENSORS", "XYZ", "cross_talk", "load_matrix",
           "output_axis", "response_matrix", "seed_xyz_diagonal", "sensor_matrix", "uvw_to_xyz",
           "xyz_to_uvw", "AGREEMENT_Z", "SCHEMA", "UVWResult", "agreement", "calibrate_uvw",
           "derive_xyz", "element_ratios", "equivalent_two_pole", "STS2_UVW", "TRILLIUM_UVW"]
