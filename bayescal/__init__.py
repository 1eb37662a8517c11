"""bayescal: Bayesian orientation and response calibration of seismometers
from co-located recordings (see README.md).

The public API is re-exported here. The package is layered; each layer may
import only the layers listed before it:

    version, errors,     leaves: the version, every exception and warning,
    atomic               files and folders written atomically
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
import lazy_loader

from .version import __version__

#: Public names, each loaded from its module on first use (PEP 562), so that
#: ``bayescal --help`` or a sub-command pays only for what it uses.
__getattr__, _, _LAZY_NAMES = lazy_loader.attach(__name__, submod_attrs={
    "result.record": ["Result", "Posterior"],
    "result.schema": ["load_posterior"],
    "pair.workflow": ["calibrate", "calibrate_files"],
    "io.result": ["write_results"],
    "simulate": ["simulate_calibration", "simulate_pair", "write_network"],
    "errors": ["InputError", "InputWarning", "SpectraError", "ResponseError", "FitError",
               "ModelMisfitWarning", "NotConvergedWarning"],
})
__all__ = [*_LAZY_NAMES, "__version__"]


def __dir__():
    """The public names, those defined here included."""
    return list(__all__)
