"""What a Python user reads of a fit: ``print(result)``, the parameters'
labels, where a failed model check's warning points, and the paths
``write_report`` returns."""
from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

#: The README's late digitizer: 0.3 s, which the fit's model leaves out.
LATE = dict(duration=1800, fs=10, seed=2, timing_offset_s=0.3)


@pytest.fixture(scope="module")
def late_fit(tmp_path_factory):
    """The late pair, from its files, fitted without its criticism, and the
    warnings it gave."""
    from bayescal import calibrate_files
    from bayescal.simulate.pair import simulate_pair

    f = simulate_pair(**LATE).write(str(tmp_path_factory.mktemp("late")))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        post = calibrate_files(  # the warning's line
            ref=f["ref.mseed"], ref_xml=f["ref.xml"], sut=f["sut.mseed"], sut_xml=f["sut.xml"],
            band=(0.03, 1.0), progress=False, diagnose=False)
    return post, caught


def test_the_misfit_warning_points_at_the_users_call(late_fit):
    from bayescal.errors import ModelMisfitWarning

    _, caught = late_fit
    (w,) = [w for w in caught if issubclass(w.category, ModelMisfitWarning)]
    assert os.path.samefile(w.filename, __file__)
    with open(__file__) as fh:
        assert "# the warning's line" in fh.read().splitlines()[w.lineno - 1]
    text = str(w.message)
    assert "bayescal.criticism.diagnose.diagnose(result.state)" in text
    assert "run `bayescal diagnose`" not in text          # a Python user's next step


def test_print_is_a_short_summary_of_the_estimates(late_fit):
    post, _ = late_fit
    text, summary = str(post), post.summary()
    assert len(text) < 1500 and len(repr(post)) < 300 and "\n" not in repr(post)
    assert "model check failed" in repr(post)
    for cid, line in zip(post.channel_ids, text.splitlines()[2:]):
        assert line.strip().startswith(f"{cid}:")
        ch = summary["channels"][cid]
        angle = "tilt_deg" if "tilt_deg" in ch else "azimuth_deg"
        lo, hi = ch[angle]["ci95"]
        assert f"{ch[angle]['median']:.3f} [{lo:.3f}, {hi:.3f}] deg" in line
    assert "model check: failed" in text


def test_labels_say_what_each_coordinate_moves():
    """A horizontal channel's first tangent-plane coordinate turns its
    azimuth (the second its dip), a vertical's tilt it toward east and
    north, as the labels say; the internal names stay the keys."""
    from bayescal.core.orientation.geometry import Sphere, azimuth_dip, unit_vector
    from bayescal.result.labels import parameter_label

    t = np.tan(np.radians(2.0))
    north = Sphere(v0=unit_vector(0.0, 0.0))
    az, dip = azimuth_dip(north.vectors(np.array([[t, 0.0], [0.0, t]])))
    assert np.allclose([az[0], dip[0], dip[1]], [2.0, 0.0, 2.0])
    assert parameter_label("XX.S.10.BH1:orient_a").startswith("BH1 azimuth offset")
    assert parameter_label("XX.S.10.BH1:orient_b").startswith("BH1 dip offset")
    up = Sphere(v0=unit_vector(0.0, -90.0))
    az, _ = azimuth_dip(up.vectors(np.array([[t, 0.0], [0.0, t]])))
    assert np.allclose(az, [90.0, 0.0])                      # east, then north
    assert parameter_label("XX.S.10.BHZ:orient_a", vertical=True) == \
        "BHZ tilt toward east (tangent plane, rad)"
    assert parameter_label("XX.S.10.BHZ:orient_b", vertical=True).startswith(
        "BHZ tilt toward north")
    assert parameter_label("XX.S.10.BHZ:log_gain") == "BHZ log gain"
    assert parameter_label("odd") == "odd"


def test_a_results_labels_follow_its_names(late_fit):
    post, _ = late_fit
    assert len(post.labels) == len(post.names)
    assert post.labels[post.names.index("XX.SIM.10.BHZ:orient_a")].startswith("BHZ tilt")
    assert post.labels[post.names.index("XX.SIM.10.BH2:orient_a")].startswith(
        "BH2 azimuth offset")
    assert post.summary()["convergence"]     # the internal keys still key the summary


def test_write_report_returns_absolute_paths(late_fit, tmp_path, monkeypatch):
    from bayescal import write_results
    from bayescal.report.fit import write_report

    post, _ = late_fit
    write_results(post, str(tmp_path / "fit"))
    monkeypatch.chdir(tmp_path)
    paths = write_report("fit")                  # a relative folder
    assert paths[0] == str(tmp_path / "fit" / "report.pdf")
    assert all(os.path.isabs(p) and os.path.isfile(p) for p in paths)
