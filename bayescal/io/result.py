"""A fit's result on disk: ``result.json``, ``samples.npz`` and
``diagnostics.npz`` (:mod:`bayescal.result.schema`), with the SUT's
corrected StationXML beside them (:func:`write_results`)."""
from __future__ import annotations

import os

from ..result.schema import load as load_posterior, save as save_posterior, write_json

__all__ = ["load_posterior", "save_posterior", "write_json", "write_results"]


def write_results(result, folder):
    """Write everything ``bayescal fit`` writes (without the report) into
    ``folder``.

    Parameters
    ----------
    result : Result
        From :func:`bayescal.calibrate` or :func:`bayescal.calibrate_files`.
    folder : str
        Output folder (created when missing).

    Returns
    -------
    list of str
        The paths written: ``result.json``, ``samples.npz``,
        ``diagnostics.npz`` and, when the result holds the SUT's metadata
        (``result.sut_inventory``, as a fit from :func:`bayescal.calibrate`
        or :func:`bayescal.calibrate_files` does), ``sut_corrected.xml``.
        Each file is written atomically.
    """
    from .stationxml import write_corrected

    save_posterior(result, folder)
    names = ["result.json", "samples.npz"] + (["diagnostics.npz"] if result.diagnostics
                                              else [])
    inv = result.sut_inventory
    if inv is not None:
        crit = result.criticism or {}
        improved = result.improved
        use = improved if crit.get("stationxml") == "improved model" and improved else result
        write_corrected(inv, use, os.path.join(folder, "sut_corrected.xml"),
                        criticism=crit if use is improved else None)
        names.append("sut_corrected.xml")
    return [os.path.join(folder, n) for n in names]
