"""The corrected StationXML writes the SUT's corner as the data see it
(bayescal.criticism.effects.SutCorner.sut_response through
bayescal.io.relative_response): on ``flat`` metadata, the pendulum's two
poles and two zeros in a stage of their own. Read back with ObsPy, the
written response over the reference's metadata is the headline curve."""
from __future__ import annotations

import warnings

import numpy as np
import pytest


@pytest.fixture(scope="module")
def flat_pair(tmp_path_factory):
    import bayescal
    from bayescal.io.result import write_corrected_result
    from bayescal.simulate import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=4.0, seed=3, sut_response=((120.0, 0.707, 750.0),) * 3,
                        nominal_response=(120.0, 0.707, 750.0),
                        ref_response=(120.0, 0.707, 1500.0), noise_in_counts=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                                 sut_xml="flat", seed=0, progress=False)
    path = tmp_path_factory.mktemp("corner") / "sut_corrected.xml"
    write_corrected_result(res.sut_inventory, res, str(path))
    return sim, res, path


def test_written_corner_is_the_headline_curve(flat_pair):
    """The corner heads the result; each channel's written response (ObsPy's
    evalresp, velocity) over the reference's metadata matches the headline
    curve's median (result.response_curve) within 1.5 % in amplitude and
    0.01 rad in phase at its first, middle and last frequency (the curve's
    median over draws against the response at the parameters' medians),
    and the flat stage is followed by one stage with two zeros at the
    origin and two poles."""
    from obspy import UTCDateTime, read_inventory

    sim, res, path = flat_pair
    assert (res.meta.headline or {}).get("effects") == ["sut_corner"], res.meta.headline
    inv = read_inventory(str(path))
    rc = res.response_curve
    f = np.asarray(rc["freq_hz"])
    pick = [0, f.size // 2, f.size - 1]
    t0 = UTCDateTime(res.meta.starttime)
    for cid, ch in rc["channels"].items():
        resp = inv.get_response(cid, t0)
        stage = resp.response_stages[1]
        assert np.allclose(stage.zeros, 0.0) and len(stage.poles) == 2, (stage.zeros, stage.poles)
        h = resp.get_evalresp_response_for_frequencies(f[pick], output="VEL")
        href = sim.ref_inventory.get_response(ch["reference"], t0) \
            .get_evalresp_response_for_frequencies(f[pick], output="VEL")
        r = h / href
        amp = np.asarray(ch["amplitude"]["median"])[pick]
        phase = np.asarray(ch["phase_rad"]["median"])[pick]
        np.testing.assert_allclose(np.abs(r), amp, rtol=0.015)
        np.testing.assert_allclose(np.angle(r * np.exp(-1j * phase)), 0.0, atol=0.01)
