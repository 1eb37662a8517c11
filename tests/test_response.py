"""Responses: ObsPy evaluation against an independent construction, and the
parametric two-pole family."""
import numpy as np
import pytest
from obspy.core.inventory.response import Response

from bayescal.core.response.family import TwoPoleFamily, evaluate_velocity_response, paz_velocity_response
from bayescal.simulate.pair import DIGITIZER_GAIN, velocity_response

F = np.geomspace(0.003, 8.0, 40)


def test_obspy_evaluation_matches_independent_paz():
    resp = velocity_response(120.0, 0.707, 1500.0)
    h_obspy = evaluate_velocity_response(resp, F)
    h_ours = paz_velocity_response(F, 120.0, 0.707, 1500.0, digitizer_gain=DIGITIZER_GAIN)
    assert np.allclose(h_obspy / h_ours, 1.0, atol=1e-10)
    # the gain at the normalisation frequency (1 Hz) is the sensitivity
    assert abs(evaluate_velocity_response(resp, [1.0])[0]) == pytest.approx(1500.0 * DIGITIZER_GAIN)


def test_family_reads_nominal_and_ratio_gives_new_response():
    nominal = velocity_response(30.0, 0.707, 750.0)
    fam = TwoPoleFamily.from_response(nominal)
    assert (fam.period_s, fam.damping, fam.gain) == pytest.approx((30.0, 0.707, 750.0))
    h_new = evaluate_velocity_response(nominal, F) * fam.ratio(F, 27.0, 0.65, 760.0)[0]
    truth = paz_velocity_response(F, 27.0, 0.65, 760.0, digitizer_gain=DIGITIZER_GAIN)
    assert np.allclose(h_new / truth, 1.0, atol=1e-10)
    # vectorised over walkers
    r = fam.ratio(F, np.array([30.0, 27.0]), np.array([0.707, 0.65]), np.array([750.0, 760.0]))
    assert r.shape == (2, F.size) and np.allclose(r[0], 1.0)


def test_family_converts_hertz_poles():
    w0, h = 2 * np.pi / 20.0, 0.6
    p = -h * w0 + 1j * w0 * np.sqrt(1 - h * h)
    resp = Response.from_paz(zeros=[0j, 0j], poles=[p / (2 * np.pi), np.conj(p) / (2 * np.pi)],
                             stage_gain=800.0, pz_transfer_function_type="LAPLACE (HERTZ)")
    fam = TwoPoleFamily.from_response(resp)
    assert fam.period_s == pytest.approx(20.0) and fam.damping == pytest.approx(0.6)
