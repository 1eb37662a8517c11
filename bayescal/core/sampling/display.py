"""What a running chain says (:func:`bayescal.core.sampling.mcmc.sample`'s
``progress``): on a terminal a bar toward the convergence rule; without one
(a log) one line per phase and per check of the rule: the steps done of
those planned, tau so far and where each target of the rule stands; nothing
when progress is off."""
from __future__ import annotations

import sys
import time

import numpy as np

#: Without a terminal, a line every this many steps within a long run of steps.
EVERY = 1000


class NoBar:
    """Progress off: says nothing."""

    step = None

    def goal(self, *args):
        pass

    def phase(self, *args):
        pass

    def limit(self, max_steps):
        """The kept phase's step limit, known once the burn-in has ended."""
        self.max_steps = max_steps

    def close(self):
        pass


class GoalBar(NoBar):
    """Progress toward the convergence rule: the bar's total is the current
    estimate of the steps the rule needs (re-estimated at every check, so
    the time left is tqdm's estimate toward it), the postfix each target:
    kept chain in autocorrelation times, smallest ESS and largest R-hat
    against their goals."""

    def __init__(self, first, n_tau, min_ess, rhat_max):
        from tqdm.auto import tqdm
        self.goals = (n_tau, min_ess, rhat_max)
        self.bar = tqdm(total=first, unit="step", desc="sampling to convergence", leave=False,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} steps "
                                   "[{elapsed}<{remaining}]{postfix}")
        self.bar.set_postfix_str(f"goals: {n_tau} tau, ESS {min_ess}, R-hat < {rhat_max}")

    def step(self):
        self.bar.update(1)

    def goal(self, need_steps, kept_tau, ess, rhat, tau=None, done=None):
        """New estimate of the steps needed (the next check of the rule),
        and where each target stands (``tau``: the largest so far;
        ``done``: the chain's steps so far)."""
        n_tau, min_ess, rhat_max = self.goals
        self.bar.total = max(int(np.ceil(need_steps)), self.bar.n)
        self.bar.set_postfix_str(f"chain {kept_tau:.0f}/{n_tau} tau, ESS {ess:.0f}/{min_ess}, "
                                 f"R-hat {rhat:.3f} (< {rhat_max})")

    def close(self):
        self.bar.close()


class LogLines(NoBar):
    """Without a terminal (a log file): a line when each phase ends, and one
    at every check of the rule (steps done of those planned, tau so far)."""

    def __init__(self, n_tau, min_ess, rhat_max, max_steps):
        self.goals, self.max_steps, self.done = (n_tau, min_ess, rhat_max), max_steps, 0
        self.planned, self.t0 = 0, time.monotonic()

    def step(self):
        self.done += 1
        if self.done % EVERY == 0 and self.done < self.planned:   # within a long run of steps
            _say(f"sampling to convergence: {self.done} steps done of {self.planned} planned "
                 f"({self._seconds()})")

    def phase(self, label, steps, acceptance):
        """A phase of the sampler ended."""
        _say(f"sampling, {label}: {steps} steps, acceptance {acceptance:.2f} "
             f"({self._seconds()})")

    def goal(self, need_steps, kept_tau, ess, rhat, tau=None, done=None):
        n_tau, min_ess, rhat_max = self.goals
        done = self.done if done is None else done
        self.planned = int(np.ceil(need_steps)) + self.done - done
        tau_text = f"; tau {tau:.1f}" if tau is not None else ""
        _say(f"sampling to convergence: {done} steps done of {need_steps:.0f} planned "
             f"(at most {self.max_steps} after the burn-in){tau_text}; "
             f"chain {kept_tau:.0f}/{n_tau} tau, ESS {ess:.0f}/{min_ess}, "
             f"R-hat {rhat:.3f} (< {rhat_max}) ({self._seconds()})")

    def _seconds(self):
        return f"{time.monotonic() - self.t0:.1f} s since the sampler started"


def _say(text):
    print(text, file=sys.stderr, flush=True)


def progress_display(enabled, first, n_tau, min_ess, rhat_max, max_steps):
    """A progress bar on a terminal, lines in a log, or nothing."""
    if not enabled:
        return NoBar()
    if not getattr(sys.stderr, "isatty", lambda: False)():
        return LogLines(n_tau, min_ess, rhat_max, max_steps)
    return GoalBar(first, n_tau, min_ess, rhat_max)
