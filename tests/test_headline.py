"""The headline is the model the verdict chooses: on the README's clock
example (the SUT's digitizer 0.3 s late), the console table, result.json's
``channels``, the report, a batch's results.csv and flags.csv and the
corrected StationXML all carry the improved model's estimates, say so, and
keep the rejected fit in one place (result.json's ``rejected_fit``, one
report page)."""
from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re

import numpy as np
import pytest

from bayescal.cli import main
from bayescal.simulate import simulate_pair

BAND = ("0.03", "1")
SIDES = ("XX.SIM.10.BH1", "XX.SIM.10.BH2")


@pytest.fixture(scope="module")
def late(tmp_path_factory):
    """The README's clock example simulated, fitted once through the CLI:
    ``(data folder, result folder, console text, result.json, truth)``."""
    root = tmp_path_factory.mktemp("late")
    data = root / "late"
    simulate_pair(duration=1800, fs=10, seed=2, timing_offset_s=0.3).write(str(data))
    out = root / "fit_late"
    console = io.StringIO()
    with contextlib.redirect_stdout(console):
        code = main(["fit", "--ref", str(data / "ref.mseed"), "--ref-xml", str(data / "ref.xml"),
                     "--sut", str(data / "sut.mseed"), "--sut-xml", str(data / "sut.xml"),
                     "--band", *BAND, "--out", str(out), "--no-report", "--quiet"])
    assert code == 0
    result = json.loads((out / "result.json").read_text())
    truth = json.loads((data / "truth.json").read_text())["channels"]
    return data, out, console.getvalue(), result, truth


def _improved(result, cid, key):
    """The improved model's estimate as the criticism lists it."""
    return result["criticism"]["improved_estimates"][cid][key]


def test_result_json_channels_are_the_improved_models_and_hold_the_truth(late):
    _, _, _, result, truth = late
    assert result["criticism"]["verdict"] == "improved"
    head = result["meta"]["headline"]
    assert head["model"] == "improved" and head["effects"] == ["timing_offset"]
    assert "timing offset" in head["label"] and head["why"] == result["criticism"]["verdict_text"]
    for cid in SIDES:
        for key in ("azimuth_deg", "dip_deg"):
            entry, improved = result["channels"][cid][key], _improved(result, cid, key)
            assert entry["median"] == pytest.approx(improved["median"], abs=1e-9)
            assert entry["ci95"] == pytest.approx(improved["ci95"], abs=1e-9)
            lo, hi = entry["ci95"]
            assert lo <= truth[cid][key] <= hi, (cid, key, entry["ci95"], truth[cid][key])
    rejected = result["rejected_fit"]
    assert rejected["model"] == "fit" and rejected["adequacy"]["ok"] is False
    assert result["adequacy"]["ok"] is True          # the headline's model fits
    dip = rejected["channels"]["XX.SIM.10.BH1"]["dip_deg"]
    assert dip["median"] == pytest.approx(_improved(result, "XX.SIM.10.BH1", "dip_deg")
                                          ["fit_median"], abs=1e-9)
    true_dip = truth["XX.SIM.10.BH1"]["dip_deg"]
    assert not dip["ci95"][0] <= true_dip <= dip["ci95"][1]     # the fit's, which misses the truth
    assert set(rejected) >= {"channels", "convergence", "adequacy"}


def test_headline_gains_hold_the_truth_where_the_fits_do_not(late):
    """Every channel's gain under the headline lies within Z_001 standard
    deviations of the simulated 750 (level 0.001 each); the rejected fit's
    gains, biased by the clock offset's phase, lie far outside theirs."""
    from tolerance import Z_001

    _, _, _, result, truth = late
    for cid, entry in result["channels"].items():
        gain = entry["response"]["gain"]
        z = (gain["median"] - truth[cid]["gain"]) / gain["sd"]
        assert abs(z) < Z_001, (cid, gain["median"], gain["sd"])
    worst = max(abs(result["rejected_fit"]["channels"][c]["response"]["gain"]["median"]
                    - truth[c]["gain"]) / result["rejected_fit"]["channels"][c]["response"]
                ["gain"]["sd"] for c in SIDES)
    assert worst > Z_001


def _table_rows(console):
    """{channel: (azimuth, dip)} medians and 95 % bounds of the console table."""
    num = r"(-?[\d.]+) \[(-?[\d.]+), (-?[\d.]+)\]"
    rows = {}
    for line in console.splitlines():
        m = re.match(rf"(XX\.SIM\.10\.BH[12])\s+{num}\s+{num}", line)
        if m:
            rows[m.group(1)] = [float(x) for x in m.groups()[1:]]
    return rows


def test_console_table_is_result_json_and_says_under_which_model(late):
    _, _, console, result, _ = late
    lines = console.splitlines()
    table = next(k for k, line in enumerate(lines) if line.startswith("channel "))
    above = "\n".join(lines[:table])
    assert "estimates under the improved model (a timing offset between the digitizers)" in above
    rows = _table_rows(console)
    assert set(rows) == set(SIDES)
    for cid in SIDES:
        ch = result["channels"][cid]
        want = [ch[k][q] for k in ("azimuth_deg", "dip_deg") for q in ("median", "ci95")]
        want = [want[0], *want[1], want[2], *want[3]]
        assert rows[cid] == pytest.approx(want, abs=6e-4)
        assert rows[cid][0] == pytest.approx(_improved(result, cid, "azimuth_deg")["median"],
                                             abs=6e-4)


def _pages(folder):
    """``bayescal report`` of ``folder``: each page's text, spaces folded."""
    from pypdf import PdfReader

    assert main(["report", str(folder), "--full"]) == 0
    return [" ".join(p.extract_text().split()) for p in PdfReader(str(folder / "report.pdf")).pages]


@pytest.fixture(scope="module")
def pages(late):
    """The clock example's report, each page's text (spaces folded)."""
    return _pages(late[1])


def test_report_shows_the_headline_and_the_rejected_fit_on_its_own_page(late, pages):
    _, out, _, result, _ = late
    first = pages[0]
    assert "Reported: estimates under the improved model" in first
    assert "ESTIMATES UNDER THE IMPROVED MODEL" in first
    for cid in SIDES:
        for key, name in (("azimuth_deg", "azimuth"), ("dip_deg", "dip")):
            e = _improved(result, cid, key)
            row = (f"{cid} {name} (deg) {e['median']:.2f} ")
            assert row in first, row
            assert f"[{e['ci95'][0]:.2f}, {e['ci95'][1]:.2f}]" in first
    assert "DIP OFF" not in first
    rejected = [p for p in pages if "The rejected fit" in p]
    assert len(rejected) == 1
    fit_dip = result["rejected_fit"]["channels"]["XX.SIM.10.BH1"]["dip_deg"]["median"]
    assert f"XX.SIM.10.BH1 dip (deg) {fit_dip:.2f}" in rejected[0]


def test_batch_csvs_carry_the_headline_and_its_effects(late, tmp_path):
    from bayescal.report.batch import read_results

    data, _, _, _, truth = late
    plan = tmp_path / "plan.csv"
    plan.write_text("label,ref,ref_xml,sut,sut_xml,band_min,band_max\n"
                    f"late,{data / 'ref.mseed'},{data / 'ref.xml'},{data / 'sut.mseed'},"
                    f"{data / 'sut.xml'},{BAND[0]},{BAND[1]}\n")
    out = tmp_path / "out"
    assert main(["batch", "--plan", str(plan), "--out", str(out), "--workers", "1",
                 "--quiet", "--seed", "1"]) == 0
    item = json.loads((out / "late" / "result.json").read_text())
    assert item["meta"]["headline"]["model"] == "improved"
    rows = {r["channel"]: r for r in read_results(out / "results.csv")}
    for cid in SIDES:
        row = rows[cid]
        assert "timing_offset" in row["effects"].split(";")
        assert "improved model" in row["notes"]
        for key, col in (("azimuth_deg", "azimuth"), ("dip_deg", "dip")):
            e = _improved(item, cid, key)
            assert row[col] == pytest.approx(e["median"], abs=1e-9)
            assert [row[f"{col}_lo95"], row[f"{col}_hi95"]] == pytest.approx(e["ci95"], abs=1e-9)
            assert row[f"{col}_lo95"] <= truth[cid][key] <= row[f"{col}_hi95"]
    with open(out / "flags.csv", newline="") as fh:
        flags = [f for f in csv.DictReader(fh) if f["channel"] in SIDES]
    assert flags == []      # the rejected fit's dips (5-7 deg off) would be flagged


def test_corrected_stationxml_holds_the_headline(late):
    from obspy import read_inventory

    _, out, _, result, _ = late
    inv = read_inventory(str(out / "sut_corrected.xml"))
    for cid in SIDES:
        net, sta, loc, cha = cid.split(".")
        ch = inv.select(network=net, station=sta, location=loc, channel=cha)[0][0][0]
        az = _improved(result, cid, "azimuth_deg")["median"]
        assert float(ch.azimuth) == pytest.approx(az % 360.0, abs=1e-6)
        assert float(ch.azimuth) == pytest.approx(
            result["channels"][cid]["azimuth_deg"]["median"] % 360.0, abs=1e-6)
        assert float(ch.dip) == pytest.approx(_improved(result, cid, "dip_deg")["median"],
                                              abs=1e-6)
        assert any("improved model" in c.value for c in ch.comments)
    assert np.isfinite(result["criticism"]["max_moved_sd"])


def test_one_misfit_definition_printed_the_same_way(late):
    """The criticism's misfit before -> after is the fit's and the
    headline's, both against the improved model's noise estimate
    (``misfit_search``), and it falls; each model's own check (the rejected
    fit's, then the headline's) is printed beside it in the same format as
    the check lines, wherever it appears."""
    _, _, console, result, _ = late
    c = result["criticism"]
    before = result["rejected_fit"]["adequacy"]["worst"]["misfit"]
    after = result["adequacy"]["worst"]["misfit"]
    assert c["misfit_before"] == pytest.approx(before, rel=1e-12)
    assert c["misfit_after"] == pytest.approx(after, rel=1e-12)
    s = c["misfit_search"]
    assert s["after"] < 2.5 < s["before"]
    assert (f"largest standardised misfit {s['before']:.3g} -> {s['after']:.3g} with it "
            "modelled (both against the improved model's noise estimate; each model's own "
            f"check: {before:.3g} and {after:.3g};") in console
    assert f"standardised misfit {before:.3g} in" in console
    assert f"largest standardised misfit {after:.3g} in" in console


SELF_NOISE = "self-noise and sensor order are the fit's"


def test_self_noise_said_to_be_the_fits_under_the_improved_model(late, pages):
    """The self-noise and the sensor order are made for the fit's pair
    model: with the improved model in the headline, the console, page 1 and
    the self-noise page say so (result.json: meta.headline.self_noise)."""
    _, _, console, result, _ = late
    assert result["self_noise"] and result["meta"]["headline"]["self_noise"].startswith("the fit's")
    assert SELF_NOISE in console
    assert SELF_NOISE in pages[0]
    noise = [p for p in pages if "Self-noise of both sensors" in p]
    assert len(noise) == 1 and f"Model: {SELF_NOISE}" in noise[0]


def test_criticism_sentences_quote_each_models_check(late):
    """The criticism's sentences (those ``bayescal diagnose`` prints) quote
    the fit's and the improved model's own check misfits, as the console's
    check and the headline's adequacy give them; the search's common scale
    stays in result.json's ``misfit_search``."""
    _, _, _, result, _ = late
    before = result["rejected_fit"]["adequacy"]["worst"]["misfit"]
    after = result["adequacy"]["worst"]["misfit"]
    text = " ".join(result["criticism"]["sentences"])
    assert f"(largest {before:.3g}) to median" in text and f"(largest {after:.3g}), each" in text
    search = result["criticism"]["misfit_search"]
    assert f"{search['before']:.3g}" not in text


def _laplace_copy(late, tmp_path):
    """The clock example's result folder with its headline posterior made a
    Laplace approximation, as the criticism's improved model falls back to
    when its chain does not converge (meta.approximation; ESS = the draws,
    R-hat 1, no walkers)."""
    import shutil

    folder = tmp_path / "laplace"
    shutil.copytree(late[1], folder)
    res = json.loads((folder / "result.json").read_text())
    res["meta"]["approximation"] = "Laplace (Gaussian at the least-squares point), no MCMC"
    res["meta"]["sampler"] = {"library": None, "draws": 4000,
                              "approximation": "Laplace (Gaussian at the least-squares point)"}
    res["convergence"].update(ess_min=4000.0, rhat_max=1.0, tau_max=1.0, n_steps=0,
                              n_walkers=0, converged=True)
    (folder / "result.json").write_text(json.dumps(res))
    return folder, res


def test_laplace_headline_prints_no_chain_figures(late, tmp_path):
    from bayescal.cli.fit import print_summary

    folder, res = _laplace_copy(late, tmp_path)
    out = io.StringIO()
    print_summary(res, out)
    line = next(x for x in out.getvalue().splitlines() if x.startswith("convergence:"))
    assert line.startswith("convergence: Laplace approximation (no chain)")
    assert "ESS" not in line.replace("no ESS or R-hat", "") and "steps" not in line
    pages = _pages(folder)
    assert "Posterior: Laplace approximation (no chain)" in pages[0]
    assert "Sampler:" not in pages[0]
    conv = [p for p in pages if "Convergence of the sampler" in p]
    assert conv and "split R-hat" not in conv[0] and "Laplace approximation (no chain)" in conv[0]


class _Improved:
    """A stand-in for the improved model's state: the effects it models."""

    def __init__(self, effects):
        self.meta = type("Meta", (), {"effects": effects})()


def _criticism(verdict, effects, improved=None, reference_noise=False):
    from bayescal.criticism.verdict import Criticism
    return Criticism({"verdict": verdict, "verdict_text": f"the verdict {verdict}",
                      "effects": [{"name": n, "channels": list(SIDES)} for n in effects],
                      "reference_noise_modelled": reference_noise}, improved)


def _results_row(late, tmp_path, headline):
    """results.csv's row of XX.SIM.10.BH1 for the clock example's result with
    ``headline`` as its meta.headline (its criticism names the timing offset)."""
    from bayescal.report.batch import read_results, results_table

    res = dict(late[3], meta=dict(late[3]["meta"], headline=headline))
    (tmp_path / "item").mkdir()
    (tmp_path / "item" / "result.json").write_text(json.dumps(res))
    rows = read_results(results_table([{"label": "item"}], str(tmp_path)))
    return next(r for r in rows if r["channel"] == "XX.SIM.10.BH1")


@pytest.mark.parametrize("verdict", ["usable", "unexplained"])
def test_batch_effects_are_the_headlines_when_the_fit_heads(late, tmp_path, verdict):
    """Verdict usable or unexplained: the fit heads, and the effects column
    lists none of the named effects; they go to effects_not_heading."""
    from bayescal.pair.choice import headline_entry

    head = headline_entry(_criticism(verdict, ["timing_offset"], _Improved(["timing_offset"])))
    assert head["model"] == "fit" and head["effects"] == []
    assert head["not_heading"] == ["timing_offset"] and head["verdict"] == verdict
    row = _results_row(late, tmp_path, head)
    assert row["effects"] == "" and row["effects_not_heading"] == "timing_offset"
    assert "improved model" not in row["notes"]


def test_improved_model_of_the_reference_noise_alone_has_a_label(late, tmp_path):
    """An improved model that adds only the reference's self-noise (no
    catalogue effect): its headline label and the batch's notes name it,
    and the effects column lists it."""
    from bayescal.pair.choice import headline_entry

    head = headline_entry(_criticism("improved", [], _Improved([]), reference_noise=True))
    assert head["model"] == "improved" and head["label"] == "the reference's own self-noise"
    row = _results_row(late, tmp_path, head)
    assert row["effects"] == "reference_noise"
    assert "estimates under the improved model (the reference's own self-noise)" in row["notes"]


def test_usable_stationxml_comment_says_the_fit_heads_and_why(late, tmp_path):
    """Verdict usable: the corrected StationXML holds the fit's values and
    each channel's comment says that the fit's model heads, and the
    verdict's words why."""
    import dataclasses

    from obspy import read_inventory

    from bayescal.io.result import load_posterior, write_corrected_result
    from bayescal.pair.choice import headline_entry

    data, out, _, _, _ = late
    result = load_posterior(str(out))
    head = headline_entry(_criticism("usable", ["timing_offset"], _Improved(["timing_offset"])))
    result = dataclasses.replace(result, meta=result.meta.replace(headline=head))
    path = write_corrected_result(read_inventory(str(data / "sut.xml")), result,
                                  str(tmp_path / "sut_corrected.xml"))
    inv = read_inventory(path)
    for cid in SIDES:
        net, sta, loc, cha = cid.split(".")
        ch = inv.select(network=net, station=sta, location=loc, channel=cha)[0][0][0]
        said = [c.value for c in ch.comments if c.subject == "bayescal headline"]
        assert said == ["Values under the fit's model (without the effects the criticism "
                        "named), which heads the result: the verdict usable."]
        assert not any(c.subject == "bayescal criticism" for c in ch.comments)
