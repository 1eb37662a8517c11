"""What a running chain says (:func:`bayescal.core.sampling.mcmc.sample`'s
``progress``): on a terminal a bar toward the convergence rule; without one
(a log) one line per phase and per check of the rule: the steps done of
those planned, the autocorrelation time so far and where each target of the
rule stands; nothing when progress is off. Every line names what is sampled
when the caller says (``what``: "element U")."""
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
        """The chain's step limit, known once the burn-in has ended."""
        self.max_steps = max_steps

    def close(self):
        pass


def targets(kept_tau, ess, rhat, goals):
    """Where each target of the convergence rule stands, in words: the kept
    draws in autocorrelation times, the effective samples, R-hat."""
    n_tau, min_ess, rhat_max = goals
    return (f"kept draws span {kept_tau:.0f} autocorrelation times ({n_tau} asked), "
            f"{ess:.0f} effective samples ({min_ess} asked), R-hat {rhat:.3f} "
            f"(below {rhat_max} asked)")


def sampling_words(what):
    """``"sampling"``, naming what is sampled when given."""
    return f"sampling {what}" if what else "sampling"


class GoalBar(NoBar):
    """Progress toward the convergence rule: the bar's total is the current
    estimate of the steps the rule needs (re-estimated at every check, so
    the time left is tqdm's estimate toward it), the postfix each target:
    kept chain in autocorrelation times, smallest ESS and largest R-hat
    against their goals."""

    def __init__(self, first, n_tau, min_ess, rhat_max, what=None):
        from tqdm.auto import tqdm
        self.goals = (n_tau, min_ess, rhat_max)
        self.bar = tqdm(total=first, unit="step", desc=f"{sampling_words(what)} to convergence",
                        leave=False,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} steps "
                                   "[{elapsed}<{remaining}]{postfix}")
        self.bar.set_postfix_str(f"asked: {n_tau} autocorrelation times, {min_ess} effective "
                                 f"samples, R-hat below {rhat_max}")

    def step(self):
        self.bar.update(1)

    def goal(self, need_steps, kept_tau, ess, rhat, tau=None, done=None):
        """New estimate of the steps needed (the next check of the rule),
        and where each target stands (``tau``: the largest so far;
        ``done``: the chain's steps so far)."""
        self.bar.total = max(int(np.ceil(need_steps)), self.bar.n)
        self.bar.set_postfix_str(targets(kept_tau, ess, rhat, self.goals))

    def close(self):
        self.bar.close()


class LogLines(NoBar):
    """Without a terminal (a log file): a line when each phase ends, and one
    at every check of the rule (steps done of those planned, tau so far)."""

    def __init__(self, n_tau, min_ess, rhat_max, max_steps, what=None):
        self.goals, self.max_steps, self.done = (n_tau, min_ess, rhat_max), max_steps, 0
        self.planned, self.t0 = 0, time.monotonic()
        self.words = sampling_words(what)

    def step(self):
        self.done += 1
        if self.done % EVERY == 0 and self.done < self.planned:   # within a long run of steps
            _say(f"{self.words} to convergence: {self.done} steps done of {self.planned} "
                 f"planned ({self._seconds()})")

    def phase(self, label, steps, acceptance):
        """A phase of the sampler ended."""
        _say(f"{self.words}, {label}: {steps} steps, acceptance {acceptance:.2f} "
             f"({self._seconds()})")

    def goal(self, need_steps, kept_tau, ess, rhat, tau=None, done=None):
        done = self.done if done is None else done
        self.planned = int(np.ceil(need_steps)) + self.done - done
        tau_text = f"; autocorrelation time {tau:.1f} steps" if tau is not None else ""
        _say(f"{self.words} to convergence: {done} steps done of {need_steps:.0f} planned "
             f"(at most {self.max_steps}){tau_text}; {targets(kept_tau, ess, rhat, self.goals)}"
             f" ({self._seconds()})")

    def _seconds(self):
        return f"{time.monotonic() - self.t0:.1f} s since the sampler started"


def _say(text):
    print(text, file=sys.stderr, flush=True)


def progress_display(enabled, first, n_tau, min_ess, rhat_max, max_steps, what=None):
    """A progress bar on a terminal, lines in a log, or nothing; ``what``
    names what is sampled ("element U"), None for a pair's posterior."""
    if not enabled:
        return NoBar()
    if not getattr(sys.stderr, "isatty", lambda: False)():
        return LogLines(n_tau, min_ess, rhat_max, max_steps, what)
    return GoalBar(first, n_tau, min_ess, rhat_max, what)
