"""bayescal: Bayesian orientation and response calibration of seismometers
from co-located recordings (see README.md).

The public API is re-exported here. The package is layered; each layer may
import only the layers listed before it:

    version, errors,     leaves: the version, every exception and warning,
    lazy, atomic         the lazy public face of every subpackage, files
                         and folders written atomically
    result               a fit's saved result: its frozen record, meta and
                         schema (numpy and the standard library only)
    core                 plain numpy: geometry, responses, spectra, likelihood,
                         sampler, posterior
    criticism            model criticism of a fitted model (imports core only)
    io                   recordings and metadata in, band choice, results
                         and StationXML out
    pair                 a pair fit: prepare, fit, criticise, choose
    simulate             synthetic recordings with known truth (its coverage
                         study runs pair fits)
    coil                 calibration from coil signals
    report               PDF/PNG pages of every result kind
    network, cli         shells: batches on Dask, the ``bayescal`` command
"""
from .lazy import attach
from .version import __version__

#: Public name -> module defining it. Imported on first use (PEP 562), so that
#: ``bayescal --help`` or a sub-command pays only for what it uses.
_LAZY = {"Result": "bayescal.result.record", "Posterior": "bayescal.result.record",
         "calibrate": "bayescal.pair.workflow", "calibrate_files": "bayescal.pair.workflow",
         "write_results": "bayescal.io.result", "load_posterior": "bayescal.result.schema",
         "simulate_calibration": "bayescal.simulate", "simulate_pair": "bayescal.simulate",
         "write_network": "bayescal.simulate",
         **dict.fromkeys(("InputError", "InputWarning", "SpectraError", "ResponseError", "FitError",
                          "ModelMisfitWarning", "NotConvergedWarning"), "bayescal.errors")}

__all__ = ["calibrate", "calibrate_files", "write_results", "load_posterior", "Result",
           "Posterior",
           "simulate_pair",
           "simulate_calibration", "write_network", "InputError", "InputWarning", "SpectraError",
           "ResponseError", "FitError", "ModelMisfitWarning", "NotConvergedWarning", "__version__"]


__getattr__, __dir__, _ = attach(__name__, {module: [n for n, m in _LAZY.items() if m == module]
                                     for module in set(_LAZY.values())})
