"""The short-record note (bayescal/core/checks/record_length.py): said when the record
used holds fewer than 35 periods of the band's lower edge, where simulations
showed the angles' intervals too narrow (12 and 31 periods), and not where they
held (38 and 68)."""
from __future__ import annotations

import pytest

import bayescal
from bayescal.core.checks import MIN_PERIODS, record_length_entry
from bayescal.simulate import simulate_pair


def test_threshold_in_periods_of_the_lower_edge():
    assert "note" in record_length_entry(614.0, 0.02)      # 12 periods: measured too narrow
    assert "note" in record_length_entry(1536.0, 0.02)     # 31: dips too narrow
    assert "note" not in record_length_entry(768.0, 0.05)  # 38: measured inside the bands
    assert "note" not in record_length_entry(3379.0, 0.02)  # 68
    assert record_length_entry(1536.0, 0.02)["periods_of_lower_edge"] == pytest.approx(30.72)
    assert MIN_PERIODS == 35.0


@pytest.mark.parametrize("band, short", [((0.02, 1.0), True), ((0.05, 1.0), False)])
def test_fit_says_so_in_result_and_console(band, short, capsys):
    from bayescal.cli.fit import print_summary
    sim = simulate_pair(duration=900, fs=10, seed=3, coherence=0.95, noise_in_counts=True)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=band,
                              progress=False, seed=3, min_ess=100, n_tau=20)
    rl = post.summary()["meta"]["record_length"]
    # the segments used: at most the record, at least the 4-segment minimum
    assert 0.5 * 900 < rl["seconds"] <= 900 and rl["lower_edge_hz"] == pytest.approx(band[0])
    assert ("note" in rl) is short, rl
    print_summary(post.summary())
    out = capsys.readouterr().out
    assert ("short record for the band" in out) is short


def test_batch_table_carries_the_note():
    """``results.csv``'s ``notes`` column (bayescal batch): the short record
    in a few words, with one decimal (34.8 periods is not "35")."""
    from bayescal.report.batch import _notes
    meta = {"record_length": record_length_entry(1740.0, 0.02)}
    assert meta["record_length"]["periods_of_lower_edge"] == pytest.approx(34.8)
    assert "34.8 periods" in meta["record_length"]["note"]
    assert _notes(meta) == "short record (34.8 periods of 0.02 Hz)"
    assert _notes({"record_length": record_length_entry(3600.0, 0.02)}) == ""
