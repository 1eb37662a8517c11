"""bayescal: Bayesian orientation and response calibration of seismometers
from co-located recordings (see README.md).

The public API is re-exported here. The package is layered; each layer may
import only the layers listed before it:

    version, core        plain numpy: geometry, responses, spectra, likelihood,
                         sampler, posterior
    simulate             synthetic recordings with known truth (imports core;
                         its coverage study also runs io.pipeline)
    io                   recordings and metadata in, band choice, the
                         files-to-posterior pipeline, StationXML out
    criticism, coil      model criticism; calibration from coil signals
    report               PDF/PNG pages of every result kind
    network, cli         shells: batches on Dask, the ``bayescal`` command
"""
from .version import __version__
from .core.posterior import Posterior
from .io.pipeline import calibrate, calibrate_files, write_results
from .simulate import simulate_calibration, simulate_pair, write_network

__all__ = ["calibrate", "calibrate_files", "write_results", "Posterior", "simulate_pair",
           "simulate_calibration", "write_network", "__version__"]
