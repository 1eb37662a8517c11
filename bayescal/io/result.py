"""A fit's result on disk: ``result.json``, ``samples.npz`` and
``diagnostics.npz`` (:mod:`bayescal.result.schema`), with the SUT's
corrected StationXML beside them (:func:`write_results`)."""
from __future__ import annotations

import os

from ..result.schema import load as load_posterior, save as save_posterior, write_json

__all__ = ["load_posterior", "save_posterior", "write_corrected_result", "write_json",
           "write_results"]


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
        or :func:`bayescal.calibrate_files` does), ``sut_corrected.xml``
        (the headline's estimates: result.json's ``channels``).
        Each file is written atomically.
    """
    save_posterior(result, folder)
    names = ["result.json", "samples.npz"] + (["diagnostics.npz"] if result.diagnostics
                                              else [])
    inv = result.sut_inventory
    if inv is not None:
        write_corrected_result(inv, result, os.path.join(folder, "sut_corrected.xml"))
        names.append("sut_corrected.xml")
    return [os.path.join(folder, n) for n in names]


def write_corrected_result(inventory, result, path):
    """The SUT's corrected StationXML (``inventory`` with ``result``'s
    values written in, :func:`bayescal.io.stationxml.write_corrected`) at
    ``path``: the headline's values, result.json's ``channels``; when the
    criticism's improved model heads the result (``result.meta.headline``),
    each channel's comment says so and names the effects it models."""
    from .stationxml import write_corrected

    improved = (result.meta.headline or {}).get("model") == "improved"
    write_corrected(inventory, result, path, criticism=result.criticism if improved else None)
