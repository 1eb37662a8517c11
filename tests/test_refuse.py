"""What cannot be known is refused or marked (issue 13, item 4).

* a pair whose sensors share no coherence (the SUT of one simulation beside
  the reference of another, independent one), band given with --band: exit
  2, one line with every channel's coherence, nothing written;
* the same without --band: the band choice refuses, with each channel's best
  coherence;
* one SUT channel replaced by independent noise: that channel is "not
  estimable" with its coherence, the others are fitted.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from bayescal.io.band import MIN_COHERENCE
from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair


@pytest.fixture(scope="module")
def unrelated(tmp_path_factory):
    """SUT files of one simulation and reference files of another."""
    root = tmp_path_factory.mktemp("unrelated")
    a = simulate_pair(duration=1800.0, fs=10.0, seed=21).write(str(root / "a"))
    b = simulate_pair(duration=1800.0, fs=10.0, seed=22).write(str(root / "b"))
    return ["--sut", a["sut.mseed"], "--sut-xml", a["sut.xml"], "--ref", b["ref.mseed"],
            "--ref-xml", b["ref.xml"], "--quiet", "--no-report"]


@pytest.mark.parametrize("band", [["--band", "0.05", "1"], []])
def test_no_coherence_exits_2_with_the_coherence(unrelated, band, tmp_path, capsys):
    from bayescal.cli import main

    out = tmp_path / "out"
    assert main(["fit", *unrelated, "--out", str(out), *band]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    figures = {cid: float(c) for cid, c in re.findall(r"(XX\.SIM\.10\.BH[12Z]) ([0-9.]+)", err[0])}
    assert set(figures) == {"XX.SIM.10.BH1", "XX.SIM.10.BH2", "XX.SIM.10.BHZ"}, err[0]
    # independent recordings: coherence at its no-signal level, far under the threshold
    # (band choice: the best over the range, still under 0.9)
    assert all(c < (MIN_COHERENCE if band else 0.9) for c in figures.values())
    assert not out.exists()


def test_one_dead_channel_is_not_estimable_with_its_figure():
    sim = simulate_pair(duration=1800.0, fs=10.0, seed=23, sut_azimuth=(3.0, 93.0, 0.0))
    rng = np.random.default_rng(0)
    tr = sim.sut[1]
    tr.data = rng.standard_normal(tr.data.size) * np.std(tr.data)
    post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.05, 1.0),
                     progress=False)
    assert post.channel_ids == ["XX.SIM.10.BH1", "XX.SIM.10.BHZ"]
    why = post.not_estimable["XX.SIM.10.BH2"]
    c = float(re.search(r"coherence ([0-9.]+)", why).group(1))
    assert c < 0.02
    az = post.summary()["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    assert az["ci95"][0] <= 3.0 <= az["ci95"][1]
