"""bayescal: Bayesian orientation and response calibration of seismometers
from co-located recordings (see README.md)."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("bayescal")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+local"

from .pipeline import calibrate, calibrate_files, write_results  # noqa: E402
from .posterior import Posterior  # noqa: E402

__all__ = ["calibrate", "calibrate_files", "write_results", "Posterior", "__version__"]
