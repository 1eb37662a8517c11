"""The reference's self-noise given (``--ref-noise-psd``, mode ``fixed``):
the remedy for a one-channel pair, which cannot separate the reference's
noise from the ground motion (issue 12 item 3): a third co-located sensor
through ``bayescal noise``'s noise.json, or the user's own curve."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.pair.workflow import calibrate
from bayescal.errors import InputError
from bayescal.io.refnoise_file import for_channels, read_reference_noise
from bayescal.simulate.pair import self_noise_psd, simulate_pair
from tests.test_cli_fit import PY, assert_user_error, base_args, run_fit
from tests.tolerance import LEVEL, Z_001, median_mc_error


def test_known_reference_noise_removes_the_one_channel_bias():
    """A vertical huddle, both sensors equally noisy (white in counts,
    coherence 0.99 each): the quiet model's 95 % interval misses the truth
    (1); with the reference's true noise PSD given its interval holds 1 and
    its median is within 3.48 sd of it (measured 0.9756
    [0.955, 0.992] against 0.9998 [0.990, 1.010]); so does the stated
    assumption of equal self-noise, ``--ref-noise equal``, true here (1.0001
    [0.992, 1.010]); the result says which was used."""
    kw = dict(duration=3600.0, fs=10.0, seed=4, coherence=0.99, ref_coherence=0.99,
              noise_in_counts=True)
    p = simulate_pair(**kw)
    f = np.geomspace(0.005, 5.0, 400)
    ref_psd = self_noise_psd(f, **kw)[1][2]                     # reference BHZ, velocity
    table = {"*": (1.0 / f, 10 * np.log10(ref_psd * (2 * np.pi * f) ** 2))}
    fits, ess = {}, np.inf
    for name, extra in (("quiet", {}), ("fixed", {"ref_noise_psd": table}),
                        ("equal", {"ref_noise": "equal"})):
        post = calibrate(sut=p.sut.select(channel="BHZ"), sut_xml=p.sut_inventory,
                         ref=p.ref.select(channel="BHZ"), ref_xml=p.ref_inventory, band=(0.02, 1.0),
                         progress=False, seed=4, min_ess=400, n_tau=20, **extra)
        assert post.meta.reference_noise["mode"] == name
        fits[name] = post.summary()["channels"]["XX.SIM.10.BHZ"]["response"]["relative_gain"]
        ess = min(ess, post.summary()["convergence"]["ess_min"])
    # the quiet model's interval misses the truth: biased low
    lo, hi = fits["quiet"]["ci95"]
    assert hi < 1.0
    # the other two within the Bonferroni bound of two checks at level 0.001
    # (3.48 sds, the median's Monte Carlo error added)
    z2 = norm.isf(LEVEL / 4)
    for name in ("fixed", "equal"):
        lo, hi = fits[name]["ci95"]
        e = fits[name]
        assert lo < 1.0 < hi and abs(e["median"] - 1.0) < z2 * np.hypot(e["sd"], median_mc_error(e, ess)), \
            (name, e)
    assert post.meta.reference_noise["assumption"].startswith("both sensors have the same")


def test_third_sensor_noise_json_through_the_command_line(tmp_path):
    """Three co-located verticals (bayescal.simulate.selfnoise: true gains
    as in the metadata): bayescal noise, then bayescal fit of the second
    against the first at 0.01-0.05 Hz, where the first's self-noise is 10 dB
    under the ground motion. Quiet: relative gain 0.959 [0.922, 0.981]; with
    the noise.json: 1.000 [0.984, 1.022] (measured). The fit's own gains
    (``rejected_fit`` when the criticism's improved model heads)."""
    import subprocess

    from bayescal.simulate.selfnoise import simulate_colocated

    data, xml = simulate_colocated(duration=4 * 3600, fs=5.0, seed=3).write(str(tmp_path / "in"))
    noise = tmp_path / "noise"
    proc = subprocess.run([PY, "-m", "bayescal.cli", "noise", "--data", *data, "--xml", *xml,
                           "--out", str(noise)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    gains = {}
    for name, extra in (("quiet", []), ("fixed", ["--ref-noise-psd", noise / "noise.json"])):
        out = tmp_path / name
        proc = run_fit("--sut", data[1], "--sut-xml", xml[1], "--ref", data[0], "--ref-xml",
                       xml[0], "--band", "0.01", "0.05", *extra, out=out)
        assert proc.returncode == 0, proc.stderr
        res = json.loads((out / "result.json").read_text())
        rn = res["meta"]["reference_noise"]
        assert rn["mode"] == name
        fit = res.get("rejected_fit") or res      # the fit's own, whatever heads the result
        gains[name] = fit["channels"]["XS.SIM.10.BHZ"]["response"]["relative_gain"]
    assert rn["input"]["curves"] == {"XS.SIM.00.BHZ": "XS.SIM.00.BHZ"}
    assert gains["quiet"]["ci95"][1] < 1.0
    lo, hi = gains["fixed"]["ci95"]
    # one check at level 0.001: within Z_001 sds (the median's Monte Carlo error added)
    e, ess = gains["fixed"], res["convergence"]["ess_min"]
    assert lo < 1.0 < hi and abs(e["median"] - 1.0) < Z_001 * np.hypot(e["sd"], median_mc_error(e, ess)), e


def test_reference_noise_files_read_and_refused(tmp_path):
    text = tmp_path / "curve.csv"
    text.write_text("# a manufacturer's curve\nperiod_s, psd_db\n1, -180\n10, -175\n100, -160\n")
    table = read_reference_noise(str(text))
    assert list(table) == ["*"] and np.allclose(table["*"][1], [-180, -175, -160])
    doc = {"schema": "bayescal.noise/1",
           "sensors": {"II.XPFO.00.BHZ": {"period_s": [1, 10, 100], "psd_db": [-185, None, -170]}}}
    js = tmp_path / "noise.json"
    js.write_text(json.dumps(doc))
    table = read_reference_noise(str(js))
    assert np.allclose(table["II.XPFO.00.BHZ"][0], [1, 100])       # the null entry skipped
    # same station, location and component under another band code
    assert for_channels(table, ["II.XPFO.00.LHZ"], "f")[0][0] == "II.XPFO.00.BHZ"
    with pytest.raises(InputError, match="no self-noise for reference channel II.XPFO.10.BHZ"):
        for_channels(table, ["II.XPFO.10.BHZ"], str(js))
    bad = {"one column": "1\n2\n", "positive dB": "1 -180\n10 20\n", "not json": "{oops",
           "not numbers": "1 -180\nten -170\n"}
    for what, content in bad.items():
        path = tmp_path / "bad.txt"
        path.write_text(content)
        with pytest.raises(InputError, match=str(path)):
            read_reference_noise(str(path))


def test_command_line_refuses_a_bad_noise_file(sim_files, tmp_path):
    missing = tmp_path / "none.json"
    out = tmp_path / "o1"
    proc = run_fit(*base_args(sim_files), "--ref-noise-psd", missing, out=out)
    assert_user_error(proc, out, str(missing), "no such file")
    curve = tmp_path / "c.txt"
    curve.write_text("1 -180\n100 -170\n")
    out = tmp_path / "o2"
    proc = run_fit(*base_args(sim_files), "--ref-noise-psd", curve, "--ref-noise", "estimate",
                   out=out)
    assert_user_error(proc, out, "--ref-noise-psd", "give one")
