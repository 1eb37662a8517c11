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


EDGES = (0.1, 0.2, 0.4)


def windows_of(inflations, edges=EDGES):
    return [Window(0.0, 1.0, inflation=np.array(c, float), band_edges_hz=edges)
            for c in inflations]


def test_the_record_floor_is_the_median_per_band_of_one_layout():
    """Per band the median over the windows of the most common band layout;
    a window with other bands is left out; fewer than three windows of one
    layout give no floor."""
    ws = windows_of([[1.0, 4.0], [2.0, 1.0], [5.0, 2.0]]) + windows_of([[9.0, 9.0]], (0.1, 0.3, 0.4))
    floor, edges = record_floor(ws)
    np.testing.assert_allclose(floor, [2.0, 2.0])
    assert edges == EDGES
    assert record_floor(ws[:2]) == (None, None) and record_floor([]) == (None, None)
    assert below_floor(ws[0], floor, EDGES)
    assert not below_floor(windows_of([[2.0, 2.0]])[0], floor, EDGES)
    assert not below_floor(ws[3], floor, EDGES)                         # another layout
    assert not below_floor(Window(0.0, 1.0, band_edges_hz=EDGES), floor, EDGES)   # none measured


def test_only_windows_below_the_floor_are_fitted_again_with_it():
    """Floor [2.5, 2.5]: the three windows under it in some band are fitted
    again (a refit the fit refuses keeps the first fit), the one above it
    keeps its fit and is given the floor, a skipped window and a window of
    other bands are left alone."""
    ws = windows_of([[1.0, 4.0], [2.0, 1.0], [5.0, 2.0], [3.0, 3.0]])
    ws += [Window(0.0, 1.0, reason="no coherence"),
           Window(0.0, 1.0, inflation=np.array([0.1, 0.1]), band_edges_hz=(0.1, 0.3, 0.4))]
    calls = []

    def refit(k, floor):
        calls.append((k, floor.tolist()))
        if k == 2:
            return Window(0.0, 1.0, reason="the refit failed")
        return Window(0.0, 1.0, inflation=np.maximum(ws[k].inflation, floor), floor=floor,
                      band_edges_hz=EDGES, floored=True)

    out = floor_windows(ws, refit)
    assert calls == [(0, [2.5, 2.5]), (1, [2.5, 2.5]), (2, [2.5, 2.5])]
    assert [w.floored for w in out] == [True, True, False, False, False, False]
    assert out[2].fitted and out[2].inflation.tolist() == [5.0, 2.0]
    np.testing.assert_allclose(out[3].floor, [2.5, 2.5])
    assert out[3].inflation.tolist() == [3.0, 3.0]
    assert out[4] is ws[4] and out[5] is ws[5]


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


def test_a_one_value_inflation_is_not_pooled():
    """A fit that reports one inflation for several bands (the one-channel
    reference's rotation) has no per-band floor: no floor, nothing refitted."""
    ws = [Window(0.0, 1.0, inflation=np.array([c]), band_edges_hz=EDGES) for c in (1.0, 2.0, 3.0)]
    assert record_floor(ws) == (None, None)
    assert floor_windows(ws, lambda k, floor: 1 / 0) == ws


@pytest.fixture(scope="module")
def pair():
    from bayescal.simulate import simulate_pair
    return simulate_pair(duration=900.0, fs=2.0, seed=5, coherence=0.999,
                         sut_azimuth=(3.0, 93.0, 0.0))


def test_windows_pooled_by_fit_windows_and_said_in_record_json(pair, tmp_path):
    """Three simulated windows: the floor is the median of the first fits'
    inflations per band; exactly the windows under it in some band are
    fitted again, each then at or above it in every band;
    ``bayescal windows`` (its default) writes that floor, its bands and
    those windows into record.json."""
    import json

    from bayescal.cli import main
    from bayescal.record import fit_windows
    first = {}
    ws = fit_windows(ref=pair.ref, ref_xml=pair.ref_inventory, sut=pair.sut,
                     sut_xml=pair.sut_inventory, window=300.0, band=(0.1, 0.8), diagnose=False,
                     misfit_shape=float("inf"), pool_inflation=True,
                     on_window=lambda k, n, w: first.setdefault(k, w))
    floor = np.median([first[k].inflation for k in range(3)], axis=0)
    below = [bool(np.any(first[k].inflation < floor)) for k in range(3)]
    assert any(below) and [w.floored for w in ws] == below
    for w in ws:
        np.testing.assert_allclose(w.floor, floor, rtol=1e-12)
        assert np.all(w.inflation >= floor * (1 - 1e-12)) or not w.floored
    files = pair.write(str(tmp_path / "pair"))
    out = tmp_path / "rec"
    assert main(["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
                 "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1",
                 "0.8", "--window", "300", "--out", str(out), "--quiet", "--no-report"]) == 0
    doc = json.loads((out / "record.json").read_text())["inflation_floor"]
    np.testing.assert_allclose(doc["per_band"], floor, rtol=1e-9)
    assert len(doc["band_edges_hz"]) == len(floor) + 1
    assert doc["windows"] == [str(w.start)[:19] for w in ws if w.floored]


def test_the_criticism_s_models_keep_the_floor():
    """The models the criticism builds from a fit given a floor (effects
    added, here none) keep the floor, so that their noise is estimated
    under it as the fit's was."""
    from bayescal.criticism.search import with_effects
    from bayescal.pair import calibrate
    from bayescal.simulate import simulate_pair
    p = simulate_pair(duration=900.0, fs=2.0, seed=11, coherence=0.99)
    floor = np.full(3, 7.0)
    r = calibrate(ref=p.ref, ref_xml=p.ref_inventory, sut=p.sut, sut_xml=p.sut_inventory,
                  band=(0.1, 0.8), diagnose=False, seed=1, progress=False,
                  misfit_shape=float("inf"), inflation_floor=floor)
    model = r.state.model
    assert model.inflation_floor is floor
    m = with_effects(model, [])
    assert m.inflation_floor is floor
    m.estimate_noise(r.state.theta_ls)
    assert np.all(m.noise.inflation >= 7.0)


def test_the_one_channel_reference_s_rotation_keeps_its_floor():
    """One horizontal reference channel (ASL's rotation of the SUT's two
    horizontals): its one inflation held at the floor, its azimuth's 95 %
    width grown by about sqrt(floor / inflation)."""
    from bayescal.pair import calibrate
    from bayescal.simulate import simulate_pair
    p = simulate_pair(duration=900.0, fs=2.0, seed=11, coherence=0.99,
                      sut_azimuth=(10.0, 100.0, 0.0))
    kw = dict(ref=p.ref.select(channel="MHN"), ref_xml=p.ref_inventory,
              sut=p.sut.select(channel="MH[12]"), sut_xml=p.sut_inventory, band=(0.1, 0.8),
              diagnose=False, seed=1, progress=False)
    a = calibrate(**kw)
    c = float(np.ravel(a.meta.noise_inflation)[0])
    b = calibrate(**kw, inflation_floor=np.array([4.0 * c]))
    assert float(np.ravel(b.meta.noise_inflation)[0]) == pytest.approx(4.0 * c)
    cid = a.channel_ids[0]
    wa = np.diff(a.channels[cid]["azimuth_deg"]["ci95"])[0]
    wb = np.diff(b.channels[cid]["azimuth_deg"]["ci95"])[0]
    assert wb / wa == pytest.approx(2.0, rel=0.15)


@pytest.mark.parametrize("ref_noise", ["quiet", "estimate"])
def test_both_likelihoods_hold_the_floor(ref_noise):
    """The base model (the reference taken as quiet) and the
    errors-in-variables model (its noise estimated): every band's
    inflation at or above the floor given."""
    from bayescal.pair import calibrate
    from bayescal.simulate import simulate_pair
    p = simulate_pair(duration=900.0, fs=2.0, seed=11, coherence=0.99)
    kw = dict(ref=p.ref, ref_xml=p.ref_inventory, sut=p.sut, sut_xml=p.sut_inventory,
              band=(0.1, 0.8), diagnose=False, seed=1, progress=False,
              misfit_shape=float("inf"), ref_noise=ref_noise)
    c = np.asarray(calibrate(**kw).meta.noise_inflation, float)
    floor = np.full(c.shape, 1.5 * c.max())
    got = np.asarray(calibrate(**kw, inflation_floor=floor).meta.noise_inflation, float)
    np.testing.assert_allclose(got, floor, rtol=1e-12)
