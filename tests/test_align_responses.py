"""A side's responses are evaluated once per distinct response: the values
are each channel's own evaluation, to the bit."""
from __future__ import annotations

import copy

import numpy as np

from bayescal.io import align


def test_equal_responses_share_one_evaluation(monkeypatch):
    import obspy

    inv = obspy.read_inventory()            # ObsPy's example: two different responses
    rs = [c.response for n in inv for s in n for c in s]
    a, b = rs[0], next(r for r in rs if r != rs[0])
    c = copy.deepcopy(a)                    # a's poles and zeros, another sensitivity
    c.instrument_sensitivity.value *= 1.7
    c.response_stages[0].stage_gain *= 1.7
    responses = [a, copy.deepcopy(a), b, a, c]  # equal by value, by identity, different, gain only
    f = np.linspace(0.01, 10.0, 500)
    original = align.evaluate_velocity_response
    own = np.array([original(r, f) for r in responses])
    calls = []

    def counted(r, freqs):
        calls.append(r)
        return original(r, freqs)

    monkeypatch.setattr(align, "evaluate_velocity_response", counted)
    side = align.Side(ids=list("abcde"), data=np.zeros((5, 8)), vectors=np.eye(3)[[0, 1, 2, 2, 0]],
                      responses=responses, azimuths=[0.0] * 5, dips=[0.0] * 5)
    got = side.response_fn()(f)
    assert len(calls) == 3
    assert np.array_equal(got, own) and not np.array_equal(got[0], got[2])
    assert np.allclose(np.abs(got[4] / got[0]), 1.7)
