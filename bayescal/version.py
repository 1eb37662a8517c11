"""The installed version of bayescal (a leaf module: imports nothing of bayescal)."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("bayescal")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+local"
