"""Orthogonality of the SUT's horizontals (issue 14 item 14): the angle
between their axes, with its interval, in the summary (result.json), the
printed table and the report's rows."""
from __future__ import annotations

import io

import numpy as np

import bayescal
from bayescal.simulate.pair import simulate_pair
from tests.closed_forms import azimuth_crb_deg, azimuth_sd_upper_deg, sd_mc_factor
from tests.conftest import SIM_BAND, SIM_KW
from tests.tolerance import Z_001, median_mc_error


def test_non_orthogonal_horizontals_are_measured():
    pair = simulate_pair(**{**SIM_KW, "sut_azimuth": (3.0, 94.5, 0.0),
                            "sut_dip": (0.0, 0.0, -89.5)})
    post = bayescal.calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    summary = post.summary()
    e = summary["orthogonality_deg"]["XX.SIM.10.BH1/XX.SIM.10.BH2"]
    assert e["ci95"][0] < 91.5 < e["ci95"][1]
    # the angle is the difference of two azimuths fitted from independent
    # noise: its sd is between the hypot of their Cramer-Rao bounds and of
    # their Welch bounds (tests/closed_forms.py), widened by the sd's Monte
    # Carlo error; its median within Z_001 sds of the truth
    ess = summary["convergence"]["ess_min"]
    used = summary["meta"]["data_used"]
    crb = [azimuth_crb_deg(pair, SIM_BAND, az) for az in (3.0, 94.5)]
    upper = [azimuth_sd_upper_deg(c, used["segments"] / used["segments_possible"]) for c in crb]
    mc = sd_mc_factor(ess, Z_001)
    assert np.hypot(*crb) * (1 - mc) <= e["sd"] <= np.hypot(*upper) * (1 + mc), (e, crb, upper)
    assert abs(e["median"] - 91.5) < Z_001 * np.hypot(e["sd"], median_mc_error(e, ess)), e

    from bayescal.cli.fit import print_summary
    from bayescal.report.tables import angle_rows

    text = io.StringIO()
    print_summary(summary, text)
    assert "angle XX.SIM.10.BH1/XX.SIM.10.BH2" in text.getvalue()
    rows, _ = angle_rows(post, summary, 1.0)
    row = [r for r in rows if r.quantity == "orthogonality"][0]
    assert row.median == e["median"] and row.deviation == e["median"] - 90.0
