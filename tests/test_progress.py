"""The sampling progress bar (issue 14 item 15): it shows progress toward
the convergence targets (kept chain in autocorrelation times, ESS, R-hat,
each against its goal), with a total that is the sampler's own estimate of
the steps needed, so tqdm gives a time estimate; the chain does not depend
on the display."""
from __future__ import annotations

import re

import numpy as np

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
    assert re.search(r"chain \d+/50 tau, ESS \d+/2000, R-hat \d\.\d{3} \(< 1\.01\)", last), last
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d", last), last
    # the total is the step count at which the rule held: the bar ends full
    n, total = map(int, re.search(r"(\d+)/(\d+) steps", last).groups())
    assert n == total == chain.n_steps, (last, chain.n_steps)
    assert "100%" in last
    # the reported numbers are the chain's
    ess = int(re.search(r"ESS (\d+)/", last).group(1))
    assert ess == int(f"{chain.ess.min():.0f}")
    # the display does not change the chain
    quiet = sample(m, np.zeros(3), 0.1 * np.eye(3), seed=3, min_ess=2000, progress=False)
    np.testing.assert_array_equal(quiet.samples, chain.samples)


def test_one_line_in_a_log(capsys):
    """Without a terminal (stderr to a file or pipe) the sampling writes one
    whole line when it ends: no carriage-return frames piling up."""
    chain = sample(Gaussian(), np.zeros(3), 0.1 * np.eye(3), seed=3, min_ess=2000, progress=True)
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("sampling to convergence: "), err
    assert f"{chain.n_steps} steps" in lines[0] and f"ESS {chain.ess.min():.0f}/2000" in lines[0]
