"""A fit's result on disk: ``result.json``, ``samples.npz`` and
``diagnostics.npz`` (:mod:`bayescal.result.schema`), with the SUT's
corrected StationXML beside them (:func:`write_results`)."""
from __future__ import annotations

import os

from ..result.schema import load as load_posterior, save as save_posterior, write_json

__all__ = ["headline_text", "load_posterior", "save_posterior", "write_corrected_result",
           "write_json", "write_results"]


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
    values written in, :func:`bayescal.io.stationxml.corrected_inventory`)
    at ``path``, atomically: the headline's values, result.json's
    ``channels``; when the criticism ran, each channel's comment says
    under which model the values are and why (:func:`headline_text`), and
    when its improved model heads the result, names the effects it models.
    Returns ``path``."""
    from obspy import UTCDateTime
    from obspy.core.inventory.util import Comment

    from ..atomic import atomic_path
    from .stationxml import corrected_inventory, find_channel

    head = result.meta.headline or {}
    improved = head.get("model") == "improved"
    inv = corrected_inventory(inventory, result, criticism=result.criticism if improved else None)
    text = headline_text(head)
    if text:
        time = UTCDateTime(result.meta.starttime) if result.meta.starttime else None
        for cid in result.channels:
            find_channel(inv, cid, time).comments.append(
                Comment(value=text, subject="bayescal headline"))
    with atomic_path(path) as tmp:
        inv.write(tmp, format="STATIONXML", validate=False)
    return path


def headline_text(head):
    """The corrected StationXML's words on which model's values it holds
    and why (``head``: ``meta.headline``), or None when no criticism ran."""
    if not head.get("why"):
        return None
    if head.get("model") == "improved":
        return (f"Values under the improved model of bayescal's model criticism "
                f"({head.get('label')}), which heads the result: {head['why']}.")
    return ("Values under the fit's model (without the effects the criticism named), which "
            f"heads the result: {head['why']}.")
