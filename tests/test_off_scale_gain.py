"""A pair whose metadata disagree in scale by orders of magnitude (the
reference's StationXML without its digitizer's gain) is refused right after
the least squares (:func:`bayescal.core.checks.gain_bounds.off_scale`): one
line naming each channel and the gain the spectra imply, the metadata to
check and the option that helps; exit 2, within a small work budget, nothing
sampled or written."""
from __future__ import annotations

import re

import pytest

from bayescal.core import Budget
from bayescal.simulate.pair import DIGITIZER_GAIN, simulate_pair

#: The factor the reference's metadata miss: its sensitivity 1e5 times too small.
MISSING = 1e5
#: The model evaluations the refusal may cost (it costs none).
SMALL_WORK = 100
#: The simulated sensors' gain (V per m/s), the same for both.
GAIN = 1500.0


@pytest.fixture(scope="module")
def no_digitizer(tmp_path_factory):
    """A short simulated pair (20 min at 10 Hz) whose reference StationXML
    gives its sensitivity 1e5 times too small: the command line's inputs."""
    from bayescal import io

    root = tmp_path_factory.mktemp("off_scale")
    files = simulate_pair(duration=1200.0, fs=10.0, seed=44,
                          sut_response=((120.0, 0.707, GAIN),) * 3,
                          nominal_response=(120.0, 0.707, GAIN)).write(str(root / "pair"))
    ref_xml = str(root / "ref_short.xml")
    io.two_pole_inventory(io.read_waveforms(files["ref.mseed"]), period_s=120.0, damping=0.707,
                          gain=GAIN * DIGITIZER_GAIN / MISSING).write(ref_xml, format="STATIONXML")
    return ["--ref", files["ref.mseed"], "--ref-xml", ref_xml, "--sut", files["sut.mseed"],
            "--sut-xml", files["sut.xml"], "--band", "0.05", "1", "--quiet", "--no-report"]


@pytest.mark.parametrize("response", [[], ["--fit-response", "none"]])
def test_metadata_off_in_scale_are_refused_at_once_with_the_factor(no_digitizer, response,
                                                                    tmp_path, capsys):
    """Gains fitted (the default) or held at the metadata's."""
    from bayescal.cli import main

    out = tmp_path / "out"
    whole = Budget("the whole command", 10 ** 9)
    with whole.active():
        code = main(["fit", *no_digitizer, *response, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("bayescal: error: "), err
    # each channel named with the relative gain its spectra imply: 1 / MISSING
    implied = {cid: float(v) for cid, v in
               re.findall(r"(XX\.SIM\.10\.BH[12Z]) ([0-9.]+e-?[0-9]+) \(95 %", err[0])}
    assert set(implied) == {"XX.SIM.10.BH1", "XX.SIM.10.BH2", "XX.SIM.10.BHZ"}, err[0]
    for cid, g in implied.items():
        assert g == pytest.approx(1.0 / MISSING, rel=0.05), cid
    factor = float(re.search(r"disagree in scale by about ([0-9.]+e[0-9]+)", err[0]).group(1))
    assert factor == pytest.approx(MISSING, rel=0.05)
    assert "reference's sensitivity is that much too small" in err[0]
    assert "digitizer stage of the --ref-xml and --sut-xml files" in err[0]
    assert "--sut-xml flat" in err[0]
    assert ("held with --fit-response none" in err[0]) == bool(response)
    # refused from the closed-form start, before the least squares: within a work budget
    # smaller than three steps of a 40-walker chain
    assert whole.used <= SMALL_WORK, whole.used
    assert not out.exists()
