"""The user's line, for the warnings a fit gives from inside the package."""
from __future__ import annotations


def caller_stacklevel():
    """The ``stacklevel`` of :func:`warnings.warn`, called by the function
    that calls this one, that names the first frame outside the bayescal
    package: the user's line (the outermost frame when every frame is
    bayescal's, as under the ``bayescal`` command)."""
    import inspect
    import os

    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    frame, level = inspect.currentframe().f_back, 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    return level if frame is not None else level - 1
