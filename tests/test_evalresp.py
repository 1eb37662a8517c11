"""bayescal's numpy evaluation of instrument responses gives ObsPy's evalresp
numbers (to 1e-7 relative) on every response of ObsPy's own test data
(RESP, dataless SEED and StationXML files: poles and zeros in rad/s and Hz,
digital poles and zeros, symmetric and asymmetric FIR cascades with
decimation corrections, IIR coefficients, gains off their frequency,
displacement, velocity and acceleration inputs, cm and nm units) and of the
shared real recordings' metadata; what it does not cover it hands to ObsPy,
never evaluating a response ObsPy refuses."""
from __future__ import annotations

import glob
import os
import warnings

import numpy as np
import pytest

import obspy
from bayescal.errors import NotHandled
from bayescal.core.response.evalresp import velocity_response
from bayescal.core.response.family import evaluate_velocity_response

OBSPY = os.path.dirname(obspy.__file__)
PATTERNS = ("signal/tests/data/RESP*", "io/xseed/tests/data/RESP*", "io/xseed/tests/data/*.dataless",
            "io/stationxml/tests/data/*.xml", "core/tests/data/*.xml")


def _channels(paths):
    for path in sorted(paths):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                inv = obspy.read_inventory(path)
        except Exception:
            continue
        for net in inv:
            for sta in net:
                for cha in sta:
                    if cha.response is not None and cha.response.response_stages:
                        yield path, cha


def _compare(paths):
    counts = {"same": 0, "not_handled": 0}
    bad = []
    for path, cha in _channels(paths):
        fs = cha.sample_rate if cha.sample_rate and cha.sample_rate > 0 else 1.0
        freqs = np.logspace(-3, np.log10(0.45 * fs), 60)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ref = cha.response.get_evalresp_response_for_frequencies(
                    freqs, output="VEL", hide_sensitivity_mismatch_warning=True)
        except Exception:
            ref = None
        try:
            mine = velocity_response(cha.response, freqs)
        except NotHandled:
            counts["not_handled"] += 1
            continue
        if ref is None:
            bad.append((path, cha.code, "evaluated a response ObsPy refuses"))
            continue
        err = np.max(np.abs(mine - ref) / np.abs(ref).max())
        rel = np.max(np.abs(mine - ref) / np.maximum(np.abs(ref), 1e-12 * np.abs(ref).max()))
        if rel < 1e-7 or err < 1e-12:
            counts["same"] += 1
        else:
            bad.append((os.path.basename(path), cha.code, rel))
    return counts, bad


def test_same_numbers_as_obspy_on_obspys_test_responses():
    paths = [p for pat in PATTERNS for p in glob.glob(os.path.join(OBSPY, pat))]
    if not paths:
        pytest.skip("ObsPy's test data are not installed")
    counts, bad = _compare(paths)
    assert bad == []
    assert counts["same"] >= 100, counts     # the bulk is evaluated here, not handed back


def test_same_numbers_on_bayescals_own_inventories(tmp_path):
    """The StationXML the simulator writes and the inventories bayescal builds
    from GSE2 poles and zeros (the shared huddle pair's STS2_simp.cal form)
    and for ``flat`` metadata."""
    from bayescal.io import paz_inventory, two_pole_inventory
    from bayescal.simulate import simulate_pair

    sim = simulate_pair(duration=600, fs=20, seed=1)
    paths = []
    for name, inv in (("sut", sim.sut_inventory), ("ref", sim.ref_inventory),
                      ("paz", paz_inventory(sim.sut, poles=[-0.037 + 0.037j, -0.037 - 0.037j,
                                                            -251.3], zeros=[0j, 0j],
                                            gain=6e8, norm_freq=0.5)),
                      ("acc", paz_inventory(sim.sut, poles=[-251.3], gain=3e8,
                                            input_units="M/S**2")),
                      ("flat", paz_inventory(sim.ref)),
                      ("twopole", two_pole_inventory(sim.ref, 120.0, 0.707, 4e5))):
        path = tmp_path / f"{name}.xml"
        inv.write(str(path), format="STATIONXML")
        paths.append(str(path))
    counts, bad = _compare(paths)
    assert bad == [] and counts["not_handled"] == 0 and counts["same"] >= 12, (counts, bad)


def test_unhandled_stage_falls_back_to_obspy():
    """A response-list stage is evaluated by ObsPy (same numbers as asking it)."""
    from obspy.core.inventory.response import (InstrumentSensitivity, Response,
                                                ResponseListElement, ResponseListResponseStage)
    f = np.logspace(-2, 1, 30)
    stage = ResponseListResponseStage(
        1, 1000.0, 1.0, "M/S", "COUNTS",
        response_list_elements=[ResponseListElement(x, 1000.0, 0.0) for x in f])
    resp = Response(instrument_sensitivity=InstrumentSensitivity(1000.0, 1.0, "M/S", "COUNTS"),
                    response_stages=[stage])
    with pytest.raises(NotHandled):
        velocity_response(resp, f[1:-1])
    got = evaluate_velocity_response(resp, f[1:-1])
    np.testing.assert_allclose(np.abs(got), 1000.0 * 1000.0, rtol=1e-6)
