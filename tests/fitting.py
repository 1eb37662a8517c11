"""Fitting a pair in the tests with the two sensors named:
:func:`bayescal.calibrate` and ``calibrate_files`` take them as keywords
(``ref=, ref_xml=, sut=, sut_xml=``); these helpers keep the tests' calls
short."""
from __future__ import annotations


def fit_pair(sut, sut_xml, ref, ref_xml, **kw):
    """The posterior of ``bayescal.calibrate`` for these streams and their
    metadata (Inventory, path or ``"flat"``); ``kw`` as calibrate takes."""
    import bayescal
    return bayescal.calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, **kw)


def fit_sim(sim, **kw):
    """:func:`fit_pair` of a :class:`bayescal.simulate.pair.SimulatedPair`."""
    return fit_pair(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory, **kw)


def pair_spectra(sim, band):
    """The cross-spectra of a simulated pair over ``band`` (Hz), computed as
    the fit computes them (aligned, deconvolved by the metadata responses,
    default segments), without fitting."""
    from bayescal.core.spectra.welch import cross_spectra
    from bayescal.io.align import align

    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
    return cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), band,
                         sut_ids=s.ids, ref_ids=r.ids)
