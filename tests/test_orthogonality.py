"""Orthogonality of the SUT's horizontals (issue 14 item 14): the angle
between their axes, with its interval, in the summary (result.json), the
printed table and the report's rows."""
from __future__ import annotations

import io

import bayescal
from bayescal.simulate.pair import simulate_pair
from tests.conftest import SIM_BAND, SIM_KW


def test_non_orthogonal_horizontals_are_measured():
    pair = simulate_pair(**{**SIM_KW, "sut_azimuth": (3.0, 94.5, 0.0),
                            "sut_dip": (0.0, 0.0, -89.5)})
    post = bayescal.calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    summary = post.summary()
    e = summary["orthogonality_deg"]["XX.SIM.10.BH1/XX.SIM.10.BH2"]
    assert e["ci95"][0] < 91.5 < e["ci95"][1]
    assert abs(e["median"] - 91.5) < 0.2 and e["ci95"][1] - e["ci95"][0] < 1.0

    from bayescal.cli.fit import print_summary
    from bayescal.report.tables import angle_rows

    text = io.StringIO()
    print_summary(summary, text)
    assert "angle XX.SIM.10.BH1/XX.SIM.10.BH2" in text.getvalue()
    rows, _ = angle_rows(post, summary, 1.0)
    row = [r for r in rows if r.quantity == "orthogonality"][0]
    assert row.median == e["median"] and row.deviation == e["median"] - 90.0
