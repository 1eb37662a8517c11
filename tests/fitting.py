"""Fitting a pair in the tests: :func:`fit_pair` calls
:func:`bayescal.calibrate` with the reference and the SUT named, whether it
takes them as keywords (``ref=, ref_xml=, sut=, sut_xml=``) or, as it did
before, positionally (SUT first)."""
from __future__ import annotations

import inspect


def _keywords(fn):
    return "ref_xml" in inspect.signature(fn).parameters


def fit_pair(sut, sut_xml, ref, ref_xml, **kw):
    """The posterior of ``bayescal.calibrate`` for these streams and their
    metadata (Inventory, path or ``"flat"``); ``kw`` as calibrate takes."""
    import bayescal
    if _keywords(bayescal.calibrate):
        return bayescal.calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, **kw)
    return bayescal.calibrate(sut, sut_xml, ref, ref_xml, **kw)


def fit_sim(sim, **kw):
    """:func:`fit_pair` of a :class:`bayescal.simulate.pair.SimulatedPair`."""
    return fit_pair(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory, **kw)


def fit_files(sut, sut_xml, ref, ref_xml, **kw):
    """``bayescal.io.pipeline.calibrate_files`` with the sensors named."""
    from bayescal.io.pipeline import calibrate_files
    if _keywords(calibrate_files):
        return calibrate_files(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, **kw)
    return calibrate_files(sut, sut_xml, ref, ref_xml, **kw)
