"""Advice that leads somewhere (:mod:`bayescal.criticism.advice`): the
criticism never advises an option the run then refuses, and after an advised
narrower band never advises a narrower one for the same mismatch.

* ObsPy's huddle pair (../shared/data; skipped without it), with the
  example's nominal two-pole metadata and with ``--sut-xml flat``: the
  advice followed as given (every option it names added to the command),
  at most three rounds: every round runs (no option refused), and a
  ``--band`` is advised at most once along the way.
* The rules one by one, on hand-made inputs: the options an advice names,
  the fit's own refusals (a period and damping fit of ``flat`` metadata, a
  band above Nyquist), the band advised only at the band's edge, keeping a
  quarter of the information, and never for a band given with ``--band``.
"""
from __future__ import annotations

import contextlib
import io
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))


def _run(argv):
    """``bayescal fit`` as a user runs it: (exit code, stderr)."""
    from bayescal.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, err.getvalue()


def _with(argv, advice):
    """``argv`` with every option ``advice`` names (replacing the option's
    earlier value)."""
    from bayescal.criticism.advice import options

    argv = list(argv)
    for text in advice:
        for flag, values in options(text):
            if flag in argv:
                k = argv.index(flag)
                del argv[k:k + 1 + len(values)]
            argv += [flag, *values]
    return argv


@pytest.mark.parametrize("sut_xml", ["nominal", "flat"])
def test_huddle_advice_followed_runs_and_narrows_the_band_once(huddle_data, tmp_path, sut_xml):
    from real_huddle import write_inputs

    ref_xml, nominal = write_inputs(huddle_data, str(tmp_path / "inputs"))
    argv = ["fit", "--ref", str(huddle_data / "ref_STS2"), "--ref-xml", ref_xml,
            "--sut", str(huddle_data / "ref_unknown"),
            "--sut-xml", nominal if sut_xml == "nominal" else "flat", "--quiet", "--no-report"]
    bands, rounds = 0, []
    for k in range(3):
        code, err = _run(argv + ["--out", str(tmp_path / f"round{k}")])
        assert code == 0, (argv, err)       # 2: an advised option refused
        crit = json.loads((tmp_path / f"round{k}" / "result.json").read_text())["criticism"]
        rounds.append(crit["advice"])
        bands += sum(a.startswith("--band") for a in crit["advice"])
        follow = [a for a in crit["advice"] if "--" in a]
        if not follow:
            break
        argv = _with(argv, follow)
    assert bands <= 1, rounds
    assert bands == 1 and rounds[0][0].startswith("--band"), rounds  # the mismatch above 5 Hz
    assert len(rounds) >= 2, rounds         # the advised band was run
    assert not any("--fit-response all" in a for a in rounds[0]) or sut_xml == "nominal"


def test_options_an_advice_names():
    from bayescal.criticism.advice import options

    assert options("--band 0.0367 4.95 (the band where the model holds)") == [
        ("--band", ["0.0367", "4.95"])]
    assert options("fit the period and damping with --fit-response all") == [
        ("--fit-response", ["all"])]
    assert options("a larger budget, e.g. --diagnose-budget 240") == [
        ("--diagnose-budget", ["240"])]
    assert options("check the metadata gain, and the order of --ref and --sut") == []


def _model(family, fs=20.0):
    return SimpleNamespace(blocks=[SimpleNamespace(family=family)], spectra=SimpleNamespace(fs=fs))


def test_an_option_the_fit_refuses_is_not_advised():
    """With ``flat`` metadata (a gain-only family) ``--fit-response all`` is
    refused by the rule the fit raises on; with a pendulum it is advised. A
    band above Nyquist is refused as the spectra refuse it."""
    from bayescal.core.fit import response_fit_refusal
    from bayescal.core.response.family import ScaleFamily, TwoPoleFamily
    from bayescal.criticism.advice import accepted, refusal

    flat = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="M/S")
    pendulum = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                             gain_units="M/S")
    advice = ["--fit-response all (period and damping fitted)", "correct the channel names"]
    assert refusal(advice[0], _model(flat)) == response_fit_refusal([flat], "all")
    assert accepted(advice, _model(flat)) == advice[1:]
    assert accepted(advice, _model(pendulum)) == advice
    assert refusal("--band 0.1 12 (...)", _model(pendulum, fs=20.0)).startswith(
        "band upper edge 12.0 Hz is above Nyquist")
    assert refusal("--band 0.1 10 (...)", _model(pendulum, fs=20.0)) is None


def _diagnosis(flags):
    """A stand-in for a diagnosis on 8 bands, 1 to 256 Hz (a factor 2
    each), whose fit and improved model misfit in the bands ``flags``."""
    flag = np.asarray(flags, bool)[:, None]
    return SimpleNamespace(band_edges=2.0 ** np.arange(len(flags) + 1), before={"flag": flag},
                           after={"flag": flag})


def test_band_advised_only_at_the_edge_keeping_a_quarter_of_the_information():
    from bayescal.criticism.advice import band as advised

    def band(flags, weights=None, given=False):
        return advised(_diagnosis(flags), band_given=given,
                       weights=np.ones(len(flags)) if weights is None else weights)

    # mismatch in the top two bands (64-256 Hz): the band below is advised, inward
    text, why = band([0, 0, 0, 0, 0, 0, 1, 1])
    assert why is None and text.startswith("--band 1 64 ")
    # mismatch at both edges: the run between them
    assert band([1, 0, 0, 0, 0, 0, 1, 1])[0].startswith("--band 2 64 ")
    # a mismatch inside the band: no band leads anywhere
    text, why = band([0, 0, 0, 1, 0, 0, 0, 0])
    assert text is None and "inside the band" in why
    # the run where the model holds keeps 3 of 13 (23 %, under a quarter)
    text, why = band([0, 0, 0, 1, 1, 1, 1, 1], weights=[1, 1, 1, 2, 2, 2, 2, 2])
    assert text is None and "23 %" in why
    # 3 of 11 (27 %) is enough
    assert band([0, 0, 0, 1, 1, 1, 1, 1], weights=[1, 1, 1, 2, 2, 2, 1, 1])[0] \
        .startswith("--band 1 8 ")
    # a band given with --band is not narrowed again
    text, why = band([0, 0, 0, 0, 0, 0, 1, 1], given=True)
    assert text is None and "--band" in why
