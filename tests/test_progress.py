"""Progress that says where a fit's time goes. The sampling progress bar
(issue 14 item 15): it shows progress toward the convergence targets (kept
chain in autocorrelation times, ESS, R-hat, each against its goal), with a
total that is the sampler's own estimate of the steps needed, so tqdm gives
a time estimate; the chain does not depend on the display. Without a
terminal (issue 44), one line per stage of a fit (bayescal.core.progress),
in the order the stages run, its numbers those the result records; nothing
with progress off or ``bayescal fit --quiet``, whose summary is unaffected."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from bayescal.core.sampling.mcmc import sample


class Gaussian:
    """A correlated 3-D Gaussian: log_prob over a (walkers, ndim) array."""

    ndim = 3

    def __init__(self):
        a = np.array([[1.0, 0.6, 0.0], [0.6, 1.0, 0.3], [0.0, 0.3, 1.0]])
        self.prec = np.linalg.inv(a)

    def log_prob(self, x):
        x = np.atleast_2d(x)
        return -0.5 * np.einsum("wi,ij,wj->w", x, self.prec, x)


def test_bar_shows_goals_and_time_left(capsys, monkeypatch):
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)     # as on a terminal
    m = Gaussian()
    chain = sample(m, np.zeros(3), 0.1 * np.eye(3), seed=3, min_ess=2000, progress=True)
    err = capsys.readouterr().err
    states = [s for s in re.split(r"[\r\n]", err) if "sampling to convergence" in s]
    assert states, err
    # every target against its goal, and tqdm's remaining-time field
    last = states[-1]
    assert re.search(r"kept draws span \d+ autocorrelation times \(50 asked\), \d+ effective "
                     r"samples \(2000 asked\), R-hat \d\.\d{3} \(below 1\.01 asked\)", last), last
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d", last), last
    # the total is the step count at which the rule held: the bar ends full
    n, total = map(int, re.search(r"(\d+)/(\d+) steps", last).groups())
    assert n == total == chain.n_steps, (last, chain.n_steps)
    assert "100%" in last
    # the reported numbers are the chain's
    ess = int(re.search(r"(\d+) effective samples \(2000 asked\)", last).group(1))
    assert ess == int(f"{chain.ess.min():.0f}")
    # the display does not change the chain
    quiet = sample(m, np.zeros(3), 0.1 * np.eye(3), seed=3, min_ess=2000, progress=False)
    np.testing.assert_array_equal(quiet.samples, chain.samples)


def test_lines_in_a_log(capsys):
    """Without a terminal (stderr to a file or pipe) the sampling writes
    whole lines: one per phase and one per check of the rule (steps done of
    those planned, tau so far), no carriage-return frames piling up."""
    chain = sample(Gaussian(), np.zeros(3), 0.1 * np.eye(3), seed=3, min_ess=2000, progress=True)
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = err.splitlines()
    assert all(ln.startswith("sampling") for ln in lines), err
    checks = [ln for ln in lines if ln.startswith("sampling to convergence: ")]
    last = checks[-1]
    assert f"{chain.n_steps} steps done of {chain.n_steps} planned" in last, last
    assert f"{chain.ess.min():.0f} effective samples (2000 asked)" in last
    assert f"autocorrelation time {chain.tau.max():.1f} steps" in last
    phases = [int(s) for s in re.findall(r"^sampling, [^:]+: (\d+) steps", err, re.M)]
    assert phases == [p["steps"] for p in chain.sampler["phases"]]
    assert sum(phases) == chain.n_steps


#: A small pair: 30 minutes at 5 Hz, a fit of a few seconds.
SMALL = dict(duration=1800.0, fs=5.0, seed=1)
BAND = ("0.05", "1")

STAGES = ("least squares:", "mode search:", "sampling, trial of a proposal around the least-squares point:",
          "sampling to convergence:")


@pytest.fixture(scope="module")
def small_files(tmp_path_factory):
    from bayescal.simulate.pair import simulate_pair
    folder = tmp_path_factory.mktemp("progress_pair")
    return simulate_pair(**SMALL).write(str(folder))


def _fit(files, out, *extra):
    from bayescal.cli import main
    return main(["fit", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
                 "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", *BAND,
                 "--no-report", "--no-diagnose", "--out", str(out), *extra])


def test_stage_lines_in_order_with_the_numbers_the_result_records(small_files, tmp_path, capfd):
    code = _fit(small_files, tmp_path / "out")
    err = capfd.readouterr().err
    assert code == 0
    first = [next(i for i, ln in enumerate(err.splitlines()) if ln.startswith(s)) for s in STAGES]
    assert first == sorted(first), err
    meta = json.loads((tmp_path / "out" / "result.json").read_text())["meta"]
    budgets = {b["stage"]: b for b in meta["budgets"]}
    for stage in ("least squares", "mode search"):
        said = re.search(rf"^{stage}: .*\((\d+) model evaluations, [\d.]+ s\)$", err, re.M)
        assert said and int(said.group(1)) == budgets[stage]["used"] > 0, err
        assert budgets[stage]["ended_by"] is None
    # each phase's line gives its steps; together they are the sampler's
    phases = [int(s) for s in re.findall(r"^sampling, [^:]+: (\d+) steps", err, re.M)]
    assert phases == [p["steps"] for p in meta["sampler"]["phases"]]
    # the last check of the rule: steps done of those planned, all of them run
    done, planned = map(int, re.findall(r"(\d+) steps done of (\d+) planned", err)[-1])
    assert done == planned == sum(phases)


def test_quiet_says_no_progress_but_the_summary(small_files, tmp_path, capfd):
    code = _fit(small_files, tmp_path / "out", "--quiet")
    captured = capfd.readouterr()
    assert code == 0
    assert not any(s.split(":")[0] in captured.err for s in STAGES), captured.err
    assert "azimuth deg" in captured.out and "convergence:" in captured.out


def test_progress_off_in_the_api(small_files, capfd):
    import obspy

    from bayescal import calibrate
    from bayescal.io import load_inventory
    sut, ref = obspy.read(small_files["sut.mseed"]), obspy.read(small_files["ref.mseed"])
    calibrate(ref=ref, ref_xml=load_inventory(small_files["ref.xml"], ref), sut=sut,
              sut_xml=load_inventory(small_files["sut.xml"], sut), band=(0.05, 1.0),
              progress=False, diagnose=False)
    assert capfd.readouterr().err == ""


def test_criticism_candidates_go_to_the_progress_channel(capsys):
    """The criticism's search log (a line per candidate) is said as progress
    where progress is on, and not where it is off."""
    from bayescal.core import progress

    with progress.shown(False):
        assert progress.logger("criticism, candidate") is None
    with progress.shown(True):
        progress.logger("criticism, candidate")("  timing_offset      BIC gain       12.5")
    assert capsys.readouterr().err == "criticism, candidate: timing_offset      BIC gain       12.5\n"


def test_a_stage_on_a_terminal_draws_a_bar_of_its_budget_then_its_line(capsys, monkeypatch):
    import sys

    from bayescal.core import Budget, progress
    from bayescal.core.budget import charge

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)     # as on a terminal
    budget = Budget("least squares", 400)
    with progress.shown(True), budget.active(), progress.stage("least squares", budget) as st:
        for _ in range(30):
            charge(10)                       # a model evaluation of 10 points at a time
        assert (st.bar.n, st.bar.total) == (300, 400)   # the bar: work used of the budget
        st.result = "9 parameters"
    err = capsys.readouterr().err
    assert "least squares:   0%|" in err, err        # drawn on stderr
    assert budget.listener is None                     # the bar let go of the budget
    assert re.search(r"^least squares: 9 parameters \(300 model evaluations, [\d.]+ s\)$",
                     err.splitlines()[-1]), err


@pytest.mark.parametrize("shown", [True, False])
def test_the_api_says_the_criticisms_progress_as_the_fits(small_files, monkeypatch, shown):
    """``calibrate(progress=...)`` turns the criticism's progress lines on
    or off with the fit's: the criticism runs where progress is said only
    when asked for."""
    import obspy

    from bayescal import calibrate
    from bayescal.core import progress
    from bayescal.io import load_inventory
    from bayescal.pair import workflow

    seen = []
    real = workflow.criticise

    def spy(*args, **kw):
        seen.append(progress.enabled())
        return real(*args, **kw)

    monkeypatch.setattr(workflow, "criticise", spy)
    sut, ref = obspy.read(small_files["sut.mseed"]), obspy.read(small_files["ref.mseed"])
    calibrate(ref=ref, ref_xml=load_inventory(small_files["ref.xml"], ref), sut=sut,
              sut_xml=load_inventory(small_files["sut.xml"], sut), band=(0.05, 1.0),
              progress=shown, diagnose=False)
    assert seen == [shown]
