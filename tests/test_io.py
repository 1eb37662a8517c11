"""Reading messy recordings: gaps, overlaps, offsets, rates, channel ids,
bad data. Numbers are checked against the signals that were put in."""
from __future__ import annotations

import warnings

import numpy as np
import obspy
import pytest
from scipy.signal import resample_poly

from bayescal import io
from bayescal.errors import InputError, InputWarning
from bayescal.io.align import align
from tests.closed_forms import check_horizontal_azimuths
from tests.conftest import SIM_BAND


def tone(freq, fs, n, t0=0.0, amp=1000.0):
    t = t0 + np.arange(n) / fs
    return amp * np.sin(2 * np.pi * freq * t) + 0.5 * amp * np.cos(2 * np.pi * 0.37 * freq * t)


def trace(data, fs, start, cha="HHZ", sta="A", loc=""):
    return obspy.Trace(np.asarray(data, float), header=dict(
        network="XX", station=sta, location=loc, channel=cha, sampling_rate=fs,
        starttime=obspy.UTCDateTime(start)))


T0 = obspy.UTCDateTime(2020, 1, 1)


def pair(sut_traces, ref_traces):
    sut, ref = obspy.Stream(sut_traces), obspy.Stream(ref_traces)
    return sut, io.flat_inventory(sut), ref, io.flat_inventory(ref)


def test_gap_becomes_nan_and_identical_overlap_is_kept():
    fs, n = 10.0, 2000
    x = tone(0.5, fs, n)
    ref = trace(x, fs, T0, sta="R")
    # SUT in two pieces: a 10-sample gap, then an overlap of 5 identical samples
    a = trace(x[:800], fs, T0)
    b = trace(x[810:1500], fs, T0 + 81.0)
    c = trace(x[1495:], fs, T0 + 149.5)
    s, r, out_fs, t0 = align(*pair([a, b, c], [ref]))
    assert out_fs == fs and t0 == T0
    got = s.data[0]
    assert np.all(np.isnan(got[800:810]))
    assert np.isfinite(got[:800]).all() and np.isfinite(got[810:]).all()
    np.testing.assert_allclose(got[810:], x[810:])


def test_conflicting_overlap_becomes_nan():
    fs, n = 10.0, 1000
    x = tone(0.5, fs, n)
    a = trace(x[:600], fs, T0)
    b = trace(x[550:] + 5.0, fs, T0 + 55.0)   # overlap 550..600 disagrees
    s, *_ = align(*pair([a, b], [trace(x, fs, T0, sta="R")]))
    assert np.all(np.isnan(s.data[0][550:600]))
    assert np.isfinite(s.data[0][:550]).all() and np.isfinite(s.data[0][600:]).all()


def test_subsample_offset_is_interpolated_onto_the_grid():
    fs, n, frac = 20.0, 4000, 0.37
    ref = trace(tone(1.3, fs, n), fs, T0, sta="R")
    # the SUT's samples are taken frac of a sample later, and labelled so
    sut = trace(tone(1.3, fs, n, t0=frac / fs), fs, T0 + frac / fs)
    s, r, _, t0 = align(*pair([sut], [ref]))
    # both channels must now hold the signal at the grid times t0 + k / fs
    truth = tone(1.3, fs, s.data.shape[1], t0=t0 - T0)
    mid = slice(100, s.data.shape[1] - 100)
    for got in (s.data[0], r.data[0]):
        ok = np.isfinite(got[mid])
        assert ok.mean() > 0.95
        err = np.max(np.abs(got[mid][ok] - truth[mid][ok]))
        assert err < 1e-3 * 1000          # 0.1 % of the amplitude
    # without the correction the error would be about 2 pi f frac / fs * amp
    assert 2 * np.pi * 1.3 * frac / fs * 1000 > 50 * err


def test_different_sampling_rates_are_brought_to_the_lower_with_antialiasing():
    fs_lo, n = 20.0, 6000
    ref = trace(tone(1.0, fs_lo, n), fs_lo, T0, sta="R")
    hi = resample_poly(tone(1.0, fs_lo, n), 2, 1)               # same signal at 40 Hz
    alias = 300.0 * np.sin(2 * np.pi * 15.0 * np.arange(2 * n) / 40.0)   # above 10 Hz
    sut = trace(hi + alias, 40.0, T0)
    s, r, fs, _ = align(*pair([sut], [ref]))
    assert fs == fs_lo and s.data.shape == r.data.shape
    ok = np.isfinite(s.data[0])
    resid = s.data[0][ok] - r.data[0][ok]
    # the 15 Hz tone would alias to 5 Hz at 300 counts; the anti-alias
    # filter must remove it to well below 1 count
    assert np.std(resid) < 1.0


def test_different_start_times_give_common_window():
    fs = 1.0
    a = trace(tone(0.1, fs, 3000), fs, T0 + 15, cha="LHN")
    b = trace(tone(0.1, fs, 3000), fs, T0 + 103, cha="LHE")
    r = trace(tone(0.1, fs, 4000), fs, T0, sta="R", cha="LH1")
    s, ref, _, t0 = align(*pair([a, b], [r]))
    assert t0 == T0 + 103
    assert s.data.shape[1] == int(T0 + 15 + 2999 - t0) + 1


def ned(azimuth_deg, dip_deg):
    """A channel's axis in north-east-down from its SEED azimuth and dip
    (dip positive down), written out here rather than taken from the
    package."""
    a, d = np.radians(azimuth_deg), np.radians(dip_deg)
    return np.array([np.cos(a) * np.cos(d), np.sin(a) * np.cos(d), np.sin(d)])


def test_channels_identified_from_codes_and_stationxml():
    st = obspy.Stream([trace([1.0, 2.0], 1.0, T0, cha=c) for c in ("LHN", "LHE", "LHZ", "LH1",
                                                                 "LH2")])
    inv = io.flat_inventory(st)
    got = {c.code: (c.azimuth, c.dip) for c in inv[0][0]}
    assert got == {"LHN": (0, 0), "LHE": (90, 0), "LHZ": (0, -90), "LH1": (0, 0), "LH2": (90, 0)}
    inv2 = io.flat_inventory(st, orientations={"LH1": (33.0, 0.0)})
    assert inv2.select(channel="LH1")[0][0][0].azimuth == 33.0
    with pytest.raises(InputError, match="orientation"):
        io.orientation_from_code("LHU")
    # the axes the fit uses follow the orientation given, not the code's
    fs, n = 10.0, 2000
    sut = obspy.Stream([trace(tone(0.5, fs, n), fs, T0, cha=c) for c in ("LH1", "LH2")])
    ref = obspy.Stream([trace(tone(0.5, fs, n), fs, T0, sta="R", cha="LHN")])
    s, *_ = align(sut, io.flat_inventory(sut, orientations={"LH1": (33.0, 0.0),
                                                            "LH2": (123.0, 4.0)}),
                  ref, io.flat_inventory(ref))
    by_id = dict(zip(s.ids, s.vectors))
    np.testing.assert_allclose(by_id["XX.A..LH1"], ned(33.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(by_id["XX.A..LH2"], ned(123.0, 4.0), atol=1e-12)


def _turned(inventory, degrees, dip=None):
    """A copy of ``inventory`` whose channels' StationXML azimuths are turned
    by ``degrees`` (and dips set to ``dip`` where given: code -> dip)."""
    import copy
    inv = copy.deepcopy(inventory)
    for ch in inv[0][0]:
        ch.azimuth = (ch.azimuth + degrees) % 360.0
        if dip and ch.code in dip:
            ch.dip = dip[ch.code]
    return inv


def test_stationxml_angles_win_over_codes(sim_pair):
    """Each side's StationXML says angles that differ from what its channel
    codes imply (SUT 1/2/Z, reference N/E/Z): the axes come from the
    StationXML, on both sides."""
    sut_inv = _turned(sim_pair.sut_inventory, 30.0, dip={"BH2": 4.0, "BHZ": -85.0})
    ref_inv = _turned(sim_pair.ref_inventory, 5.0, dip={"BHE": -2.0})
    s, r, *_ = align(sim_pair.sut, sut_inv, sim_pair.ref, ref_inv)
    got = dict(zip(s.ids + r.ids, list(s.vectors) + list(r.vectors)))
    want = {"XX.SIM.10.BH1": ned(30.0, 0.0), "XX.SIM.10.BH2": ned(120.0, 4.0),
            "XX.SIM.10.BHZ": ned(30.0, -85.0), "XX.SIM.00.BHN": ned(5.0, 0.0),
            "XX.SIM.00.BHE": ned(95.0, -2.0), "XX.SIM.00.BHZ": ned(5.0, -90.0)}
    assert set(got) == set(want)
    for cid, v in want.items():
        np.testing.assert_allclose(got[cid], v, atol=1e-12, err_msg=cid)


def test_bad_data_messages_name_the_file(tmp_path):
    fs, n = 10.0, 2000
    ref = trace(tone(0.5, fs, n), fs, T0, sta="R")
    for name, data, pattern in (("zeros", np.zeros(n), "all zeros"),
                                ("nan", np.full(n, np.nan), "no valid sample")):
        t = trace(data, fs, T0)
        t.stats.bayescal_source = f"/data/{name}.mseed"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            with pytest.raises(InputError, match=pattern) as exc:
                align(*pair([t], [ref]))
        assert f"/data/{name}.mseed" in str(exc.value)


def test_clipped_samples_warn_and_become_gaps():
    fs, n = 10.0, 3000
    x = tone(0.5, fs, n)
    clipped = np.clip(x, -900, 900)
    with pytest.warns(InputWarning, match="clipped"):
        s, *_ = align(*pair([trace(clipped, fs, T0)], [trace(x, fs, T0, sta="R")]))
    assert np.isnan(s.data[0][np.abs(x) >= 900]).all()


def test_read_waveforms_errors(tmp_path):
    with pytest.raises(InputError, match="not found") as exc:
        io.read_waveforms([str(tmp_path / "missing.mseed")])
    assert "missing.mseed" in str(exc.value)
    junk = tmp_path / "junk.mseed"
    junk.write_text("this is not seismic data\n")
    with pytest.raises(InputError, match="junk.mseed"):
        io.read_waveforms([str(junk)])
    with pytest.raises(InputError, match="junk.mseed"):
        io.read_metadata(str(junk))


def test_messy_simulated_pair_still_recovers_the_orientation(sim_pair):
    """Gaps, a late start with a sub-sample offset and a doubled sampling
    rate on the SUT: the azimuths come out as in the clean case."""
    import bayescal
    from tests.conftest import SIM_BAND

    sut = sim_pair.sut.copy()
    ref = sim_pair.ref.copy()
    fs = sut[0].stats.sampling_rate
    for tr in sut:   # twice the rate (content is below the old Nyquist)
        tr.data = resample_poly(tr.data.astype(float), 2, 1)
        tr.stats.sampling_rate = 2 * fs
    frac = 0.4 / (2 * fs)     # SUT clock labels 0.4 of its sample late
    for tr in sut:
        x = tr.data
        n = x.size
        spec = np.fft.rfft(x) * np.exp(-2j * np.pi * np.fft.rfftfreq(n, 1 / (2 * fs)) * -frac)
        tr.data = np.fft.irfft(spec, n)[200:]
        tr.stats.starttime += frac + 200 / (2 * fs)
    gapped = ref.copy()
    gapped.cutout(ref[0].stats.starttime + 1200, ref[0].stats.starttime + 1500)
    post = bayescal.calibrate(sut=sut, sut_xml=sim_pair.sut_inventory, ref=gapped, ref_xml=sim_pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    summ = post.summary()
    # medians within 3.48 sd of the truth, sds between the closed-form bounds
    check_horizontal_azimuths(summ, sim_pair, SIM_BAND)
    used = summ["meta"]["data_used"]
    assert used["segments"] < used["segments_possible"]


def _as_acceleration(inventory):
    """The same sensors described in acceleration: input M/S**2, one more
    pole at the origin, gain and A0 rescaled so the physics is unchanged."""
    import copy
    inv = copy.deepcopy(inventory)
    for ch in inv[0][0]:
        st = ch.response.response_stages[0]
        fn = st.normalization_frequency
        s = 2j * np.pi * fn
        st.poles = list(st.poles) + [0j]
        st.normalization_factor = st.normalization_factor * abs(s)
        st.stage_gain = st.stage_gain / abs(s)
        st.input_units = "M/S**2"
        ch.response.instrument_sensitivity.value /= 2 * np.pi * \
            ch.response.instrument_sensitivity.frequency
        ch.response.instrument_sensitivity.input_units = "M/S**2"
    return inv


def test_acceleration_response_is_not_misscaled(sim_pair):
    """A SUT whose StationXML gives its response in acceleration yields the
    same velocity response, and the same orientation, as in velocity."""
    import bayescal
    from tests.conftest import SIM_BAND

    acc = _as_acceleration(sim_pair.sut_inventory)
    s_vel, *_ = align(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref, sim_pair.ref_inventory)
    s_acc, *_ = align(sim_pair.sut, acc, sim_pair.ref, sim_pair.ref_inventory)
    f = np.geomspace(0.01, 4, 50)
    np.testing.assert_allclose(s_acc.response_fn()(f), s_vel.response_fn()(f), rtol=1e-6)
    post = bayescal.calibrate(sut=sim_pair.sut, sut_xml=acc, ref=sim_pair.ref, ref_xml=sim_pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    check_horizontal_azimuths(post.summary(), sim_pair, SIM_BAND)


def test_natural_and_coarse_records_are_not_called_clipped():
    rng = np.random.default_rng(1)
    fs, n = 10.0, 5000
    natural = rng.normal(0, 1000, n).round()
    coarse = rng.integers(-3, 4, n).astype(float)      # 7 distinct values
    for x in (natural, coarse):
        with warnings.catch_warnings():
            warnings.simplefilter("error", InputWarning)
            s, *_ = align(*pair([trace(x, fs, T0)], [trace(natural, fs, T0, sta="R")]))
        assert np.isfinite(s.data).all()


def test_missing_angles_in_stationxml_come_from_the_code(sim_pair):
    """A reference StationXML without azimuth and dip: the codes N, E, Z give
    the axes (north, east, up); where the angles are there, turned 5 degrees
    from the codes' here, they are used instead."""
    import copy
    inv = copy.deepcopy(_turned(sim_pair.ref_inventory, 5.0))
    for ch in inv[0][0]:
        if ch.code != "BHE":
            ch.azimuth = ch.dip = None
    s, r, *_ = align(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref, inv)
    got = dict(zip(r.ids, r.vectors))
    np.testing.assert_allclose(got["XX.SIM.00.BHN"], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(got["XX.SIM.00.BHZ"], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(got["XX.SIM.00.BHE"], ned(95.0, 0.0), atol=1e-12)


def test_two_channel_reference_gives_horizontal_azimuths_only(sim_pair):
    """Partial channel set: a reference without its vertical still gives the
    SUT's horizontal azimuths; the SUT vertical is reported not estimable."""
    import bayescal
    from tests.conftest import SIM_BAND

    ref = sim_pair.ref.copy()
    for tr in [t for t in ref if t.stats.channel.endswith("Z")]:
        ref.remove(tr)
    post = bayescal.calibrate(sut=sim_pair.sut, sut_xml=sim_pair.sut_inventory, ref=ref, ref_xml=sim_pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    summ = post.summary()
    assert list(summ["not_estimable"]) == ["XX.SIM.10.BHZ"]
    assert all(summ["channels"][cid]["kind"] == "circle" for cid in ("XX.SIM.10.BH1", "XX.SIM.10.BH2"))
    check_horizontal_azimuths(summ, sim_pair, SIM_BAND)


def test_gap_in_a_trace_to_be_resampled_spreads_over_the_filter_only():
    fs_hi, n = 40.0, 8000
    x = tone(1.0, fs_hi, n)
    x[4000:4040] = np.nan                    # one second missing
    sut = trace(x, fs_hi, T0)
    ref = trace(tone(1.0, 20.0, n // 2), 20.0, T0, sta="R")
    with pytest.warns(InputWarning, match="NaN samples"):
        s, r, fs, _ = align(*pair([sut], [ref]))
    bad = np.flatnonzero(np.isnan(s.data[0]))
    inner = bad[(bad > 100) & (bad < s.data.shape[1] - 100)]
    # the gap (samples 2000-2020 at 20 Hz) plus the anti-alias filter's reach
    assert inner.min() >= 2000 - 30 and inner.max() <= 2020 + 30 and inner.size < 100
    ok = np.isfinite(s.data[0])
    assert np.std(s.data[0][ok] - r.data[0][ok]) < 1.0


def test_reference_turned_in_its_stationxml_turns_the_sut_azimuths(sim_pair):
    """The same recordings with the reference's StationXML saying its
    horizontals point 5 degrees east of north and east: every SUT azimuth
    moves by those 5 degrees and nothing else changes (the fit is
    equivariant under a turn about the vertical), to within the Monte Carlo
    error of two medians (two-sided level 0.001 per number)."""
    from tests.conftest import SIM_BAND
    from tests.fitting import fit_pair
    from tests.tolerance import Z_001, median_mc_error

    kw = dict(band=SIM_BAND, progress=False, seed=1)
    plain = fit_pair(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref, sim_pair.ref_inventory,
                     **kw).summary()
    turned = fit_pair(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref,
                      _turned(sim_pair.ref_inventory, 5.0), **kw).summary()
    ess = min(plain["convergence"]["ess_min"], turned["convergence"]["ess_min"])
    for cid in ("XX.SIM.10.BH1", "XX.SIM.10.BH2"):
        for key, shift in (("azimuth_deg", 5.0), ("dip_deg", 0.0)):
            a, b = plain["channels"][cid][key], turned["channels"][cid][key]
            tol = Z_001 * np.hypot(median_mc_error(a, ess), median_mc_error(b, ess))
            assert abs(b["median"] - a["median"] - shift) < tol, (cid, key, a, b, tol)
            # the same posterior turned: equal sds up to their Monte Carlo
            # errors, 1 / sqrt(2 ESS) relative each, Z_001 of the difference
            assert abs(b["sd"] / a["sd"] - 1) < Z_001 / np.sqrt(ess), (cid, key, a, b)
    a, b = plain["channels"]["XX.SIM.10.BHZ"], turned["channels"]["XX.SIM.10.BHZ"]
    tol = Z_001 * np.hypot(median_mc_error(a["dip_deg"], ess), median_mc_error(b["dip_deg"], ess))
    assert abs(b["dip_deg"]["median"] - a["dip_deg"]["median"]) < tol
    # the vertical's lean (its north and east tilt components) turns with the frame too
    c, s = np.cos(np.radians(5.0)), np.sin(np.radians(5.0))
    an, ae = a["tilt_north_deg"], a["tilt_east_deg"]
    for got, (cn, ce) in ((b["tilt_north_deg"], (c, -s)), (b["tilt_east_deg"], (s, c))):
        want = cn * an["median"] + ce * ae["median"]
        tol = Z_001 * np.sqrt(median_mc_error(got, ess) ** 2 + (cn * median_mc_error(an, ess)) ** 2
                              + (ce * median_mc_error(ae, ess)) ** 2)
        assert abs(got["median"] - want) < tol, (got, want, tol)
