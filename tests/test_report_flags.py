"""One flag rule for ``bayescal report`` and ``bayescal batch``
(:func:`bayescal.report.flags.off_nominal`): a quantity is flagged off
nominal when it deviates by more than the threshold AND its 95 % interval
excludes the nominal value. Checked on a 2.5 deg deviation against the
2 deg default: flagged when the interval excludes nominal, not when it
includes it, by both reports alike (azimuth across north, dip, and a
near-vertical channel's tilt)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayescal.core.orientation import unit_vector
from bayescal.report.flags import FLAG_THRESHOLD_DEG, find_flags, off_nominal
from bayescal.report.tables import angle_rows

CID = "XX.SUT.00.BH1"
#: 95 % intervals around a median 2.5 deg off nominal: including nominal, excluding it.
INCLUDES, EXCLUDES = (-0.5, 5.5), (1.0, 4.0)


def entry(median, ci95):
    lo, hi = ci95
    return {"median": median, "ci68": [(median + lo) / 2, (median + hi) / 2], "ci95": [lo, hi]}


def report_flags(ch, azimuth, dip):
    """The fit report's flags (angle_rows) of one channel entry ``ch``,
    its sampled axis at (azimuth, dip)."""
    post = SimpleNamespace(channel_ids=[CID], kinds=["sphere"],
                           vectors=np.tile(unit_vector(azimuth, dip), (4, 1, 1)))
    return angle_rows(post, {"channels": {CID: ch}}, FLAG_THRESHOLD_DEG)[1].get(CID, [])


def batch_flags(quantity, value, ci95, nominal):
    """The batch report's off-nominal flags of one results.csv row."""
    row = {"station": "XX.SUT", "channel": CID, "reference_channels": "", "day": "2024-01-01",
           "label": "a", quantity: value, f"{quantity}_lo95": ci95[0],
           f"{quantity}_hi95": ci95[1], f"nominal_{quantity}": nominal}
    return [f for f in find_flags([row]) if f["flag"] == "off_nominal"]


def test_default_threshold_is_2_deg():
    assert FLAG_THRESHOLD_DEG == 2.0


@pytest.mark.parametrize("dev, lo, hi, flagged", [(2.5, -0.5, 5.5, False), (2.5, 1.0, 4.0, True),
                                                  (-2.5, -4.0, -1.0, True), (1.5, 1.0, 2.0, False),
                                                  (2.5, 0.0, 5.0, False)])
def test_off_nominal_needs_both_the_threshold_and_the_interval(dev, lo, hi, flagged):
    assert off_nominal(dev, lo, hi, 2.0) is flagged


@pytest.mark.parametrize("ci, flagged", [(INCLUDES, False), (EXCLUDES, True)])
def test_azimuth_across_north_flagged_alike(ci, flagged):
    # nominal 359 deg, estimate 1.5 deg: a deviation of +2.5 deg across north
    az = entry(1.5, (1.5 - 2.5 + ci[0], 1.5 - 2.5 + ci[1]))
    ch = {"nominal": {"azimuth_deg": 359.0, "dip_deg": 0.0}, "azimuth_deg": az,
          "dip_deg": entry(0.0, (-0.3, 0.3))}
    assert report_flags(ch, 1.5, 0.0) == (["AZIMUTH OFF: +2.50 deg from nominal (tolerance 2)"]
                                          if flagged else [])
    assert len(batch_flags("azimuth", az["median"], az["ci95"], 359.0)) == flagged


@pytest.mark.parametrize("ci, flagged", [(INCLUDES, False), (EXCLUDES, True)])
def test_dip_flagged_alike(ci, flagged):
    dip = entry(2.5, ci)
    ch = {"nominal": {"azimuth_deg": 90.0, "dip_deg": 0.0}, "azimuth_deg": entry(90.0, (89.7, 90.3)),
          "dip_deg": dip}
    assert report_flags(ch, 90.0, 2.5) == (["DIP OFF: +2.50 deg from nominal (tolerance 2)"]
                                           if flagged else [])
    assert len(batch_flags("dip", 2.5, ci, 0.0)) == flagged


@pytest.mark.parametrize("ci, flagged", [((0.0, 5.0), False), (EXCLUDES, True)])
def test_tilt_of_a_vertical_flagged_by_the_same_rule(ci, flagged):
    ch = {"nominal": {"azimuth_deg": 0.0, "dip_deg": -90.0},
          "azimuth_deg": {"median": None, "undefined": True}, "dip_deg": entry(-87.5, (-90, -85)),
          "tilt_deg": {**entry(2.5, ci), "holds_zero": ci[0] == 0.0},
          "tilt_toward_azimuth_deg": 30.0}
    assert report_flags(ch, 30.0, -87.5) == (["TILT OFF: +2.50 deg from nominal (tolerance 2)"]
                                             if flagged else [])
