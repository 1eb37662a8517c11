"""The record's noise inflation as a floor under each window's
(:mod:`bayescal.record.pooling`, ``inflation_floor`` of a fit): the floor's
closed form, which windows are fitted again, and that a fit given a floor
holds its inflation at or above it and widens its intervals by it."""
from __future__ import annotations

import numpy as np
import pytest

from bayescal.core.model.inflation import INFLATION_SHRINK, shrunk_inflation
from bayescal.record.pooling import below_floor, floor_windows, record_floor
from bayescal.record.windows import Window


def test_a_floor_lifts_only_the_bands_below_it():
    raw = np.array([1.0, 3.0])                  # shrunk (equal weights): [1.5, 2.5]
    np.testing.assert_allclose(shrunk_inflation(raw, INFLATION_SHRINK, floor=[2.0, 2.0]),
                               [2.0, 2.5], rtol=1e-15)


def test_a_floor_of_another_band_layout_is_refused():
    from bayescal.errors import FitError
    with pytest.raises(FitError, match="3 bands given to a fit of 2"):
        shrunk_inflation(np.ones(2), 10.0, floor=np.ones(3))


def test_the_record_floor_is_the_median_per_band():
    """Per band the median over windows; a window of another band layout
    is left out; fewer than three windows give no floor."""
    c = [np.array([1.0, 4.0]), np.array([2.0, 1.0]), np.array([5.0, 2.0]), np.array([9.0])]
    np.testing.assert_allclose(record_floor(c), [2.0, 2.0])
    assert record_floor(c[:2]) is None and record_floor([]) is None
    assert below_floor(np.array([1.0, 4.0]), np.array([2.0, 2.0]))
    assert not below_floor(np.array([2.0, 2.0]), np.array([2.0, 2.0]))
    assert not below_floor(np.array([1.0]), np.array([2.0, 2.0]))       # another layout


def test_only_windows_below_the_floor_are_fitted_again_with_it():
    t = 0.0
    inflations = [[1.0, 4.0], [2.0, 1.0], [5.0, 2.0], [3.0, 3.0]]       # floor [2.5, 2.5]
    ws = [Window(t, t + 1, inflation=np.array(c)) for c in inflations]
    ws.append(Window(t, t + 1, reason="no coherence"))
    calls = []

    def refit(k, floor):
        calls.append((k, floor.tolist()))
        return Window(t, t + 1, inflation=np.maximum(ws[k].inflation, floor), floor=floor)

    out, floor = floor_windows(ws, refit)
    np.testing.assert_allclose(floor, [2.5, 2.5])
    assert calls == [(0, [2.5, 2.5]), (1, [2.5, 2.5]), (2, [2.5, 2.5])]
    assert out[3] is ws[3] and out[4] is ws[4]
    assert [w.floored for w in out] == [True, True, True, False, False]


def test_a_fit_given_a_floor_holds_its_inflation_at_it_and_widens():
    """A simulated pair fitted with the Gaussian likelihood, then with a
    floor of twice its largest inflation: every band's inflation equals
    the floor, and the azimuths' 95 % widths grow by about sqrt(2 c_floor /
    c) (between the smallest and largest band's ratio)."""
    from bayescal.pair import calibrate
    from bayescal.record.windows import parameters
    from bayescal.simulate import simulate_pair
    p = simulate_pair(duration=900.0, fs=2.0, seed=11, coherence=0.99,
                      sut_azimuth=(10.0, 100.0, 0.0))
    kw = dict(ref=p.ref, ref_xml=p.ref_inventory, sut=p.sut, sut_xml=p.sut_inventory,
              band=(0.1, 0.8), diagnose=False, seed=1, progress=False,
              misfit_shape=float("inf"))
    a = calibrate(**kw)
    c = np.asarray(a.meta.noise_inflation, float)
    floor = np.full(c.shape, 2.0 * c.max())
    b = calibrate(**kw, inflation_floor=floor)
    np.testing.assert_allclose(np.asarray(b.meta.noise_inflation, float), floor, rtol=1e-12)
    lo, hi = np.sqrt(floor[0] / c.max()), np.sqrt(floor[0] / c.min())
    for name, (entry, _) in parameters(a).items():
        if not name.endswith("azimuth_deg"):
            continue
        ratio = np.diff(parameters(b)[name][0]["ci95"])[0] / np.diff(entry["ci95"])[0]
        assert 0.9 * lo <= ratio <= 1.1 * hi, (name, ratio, lo, hi)
