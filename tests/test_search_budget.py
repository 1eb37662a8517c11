"""The least squares and the mode search count all their work into their
budgets, and a start the mode search's budget cuts off mid-polish is no
mode (bayescal.core.budget)."""
from __future__ import annotations

import numpy as np
import pytest

from bayescal.core import Budget
from bayescal.core.budget import charge
from bayescal.core.fit import modes
from bayescal.core.fit.leastsq import refine
from bayescal.errors import OffChart

#: A linear least-squares problem: its minimum in closed form.
A = np.array([[1.0, 0.0, 0.5], [0.2, 1.0, 0.0], [0.0, 0.3, 1.0], [1.0, 1.0, 1.0],
              [0.5, -1.0, 0.2]])
B = np.array([1.0, -2.0, 0.5, 3.0, 0.7])


def test_refine_counts_its_noise_reestimates_and_final_jacobian():
    """Every evaluation of the residual (the passes, the final Jacobian) and
    every re-estimate of the noise model (5 model evaluations each here)
    counts into the budget: its ``used`` is what the calls charged."""
    calls, reestimates = [], []

    def fun(x):
        charge(1)
        calls.append(np.array(x))
        return A @ x - B

    def reestimate(theta):
        charge(5)
        reestimates.append(np.array(theta))

    budget = Budget("least squares", 10**6)
    theta, _ = refine(fun, np.zeros(3), np.full(3, -np.inf), np.full(3, np.inf), reestimate, 2,
                      budget=budget)
    np.testing.assert_allclose(theta, np.linalg.lstsq(A, B, rcond=None)[0], atol=1e-9)
    assert len(reestimates) == 3                       # first, then after each pass
    assert budget.used == len(calls) + 5 * len(reestimates)


@pytest.fixture(scope="module")
def fitted():
    import bayescal
    from bayescal.simulate.pair import simulate_pair
    import warnings
    sim = simulate_pair(duration=1800.0, fs=5.0, seed=1)
    warnings.simplefilter("ignore")          # a short chain: not converged, not needed here
    return bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                              sut_xml=sim.sut_inventory, band=(0.05, 1), progress=False,
                              diagnose=False, max_steps=50).state


def test_a_start_cut_off_mid_polish_is_not_a_mode(fitted, monkeypatch):
    """On this pair the start with MH2 mirrored runs off its chart (the
    full search counts it so). With a budget that runs out three model
    evaluations into that start's polish, the start is counted as not
    tried instead and only the first fit's mode is listed (its cut-off
    point is no optimum)."""
    model, theta = fitted.model, fitted.theta_ls
    labels = [label for label, _ in modes.starts(model, theta)]
    mirrored = next(k for k, label in enumerate(labels) if label.startswith("XX.SIM.10.MH2"))
    entries, polish = [], modes._polish

    def recorded(model_, theta_, factors, budget=None):
        entries.append(budget.used)
        return polish(model_, theta_, factors, budget)

    monkeypatch.setattr(modes, "_polish", recorded)
    _, full = modes.search(model, theta, budget=Budget("mode search", 10**7))
    assert [m["start"][:13] for m in full["modes"]] == ["closed-form s"]
    assert full["off_chart"] == 1 and "not_tried" not in full
    budget = Budget("mode search", entries[mirrored] + 3)
    _, cut = modes.search(model, theta, budget=budget)
    assert budget.ended_by == "work"
    assert [m["start"][:13] for m in cut["modes"]] == ["closed-form s"]
    assert cut["not_tried"] == len(labels) - mirrored     # it and the starts after it
    assert "off_chart" not in cut


def test_a_polish_run_off_its_chart_ends_at_no_optimum(fitted, monkeypatch):
    """Polished without the edge rule, the start with MH2 mirrored ends with
    MH2's axis at the edge of its chart (gnomonic radius above 1e6, 90 deg
    from the start) and is no optimum: turning that axis 5 and 20 degrees
    toward the first fit's raises the log-posterior (measured: by 15 and
    54). With the rule the search stops that polish and lists no mode for
    it, stopped from its Jacobian at the edge before least squares ends."""
    model, theta = fitted.model, fitted.theta_ls
    label, v = next((lb, v) for lb, v in modes.starts(model, theta)
                    if lb.startswith("XX.SIM.10.MH2"))
    k = [b.channel_id for b in model.blocks].index("XX.SIM.10.MH2")
    chart = modes.recharted(model, v)
    monkeypatch.setattr(modes, "CHART_EDGE", np.inf)
    end = modes._polish(chart, modes.theta_for(chart, v, theta), model.noise.cholesky())
    assert np.hypot(*end[chart.slices[k][0]]) > 1e6
    axes, first = chart.unpack(end[None])[0][0], model.unpack(theta[None])[0][0][k]
    centred = modes.recharted(chart, axes)
    toward = first - (first @ axes[k]) * axes[k]
    toward /= np.linalg.norm(toward)

    def turned(deg):
        w = axes.copy()
        w[k] = np.cos(np.radians(deg)) * axes[k] + np.sin(np.radians(deg)) * toward
        return float(centred.log_prob(modes.theta_for(centred, w, end)[None])[0])

    lp = [turned(d) for d in (0.0, 5.0, 20.0)]
    assert lp[1] > lp[0] + 10 and lp[2] > lp[1] + 10
    monkeypatch.undo()
    raised, watch = [], modes._EdgeWatch.__call__

    def watched(self, theta_, *args):
        try:
            return watch(self, theta_, *args)
        except OffChart:
            raised.append(np.hypot(*theta_[chart.slices[k][0]]))
            raise

    monkeypatch.setattr(modes._EdgeWatch, "__call__", watched)
    assert modes._polish(chart, modes.theta_for(chart, v, theta), model.noise.cholesky()) is None
    assert len(raised) == 1 and raised[0] < 1e6         # stopped at the edge, not at its end
    monkeypatch.undo()
    _, report = modes.search(model, theta)
    assert report["off_chart"] == 1 and len(report["modes"]) == 1


def test_joint_mirror_ruled_out_ends_where_the_single_starts_did(fitted, monkeypatch):
    """On this pair one channel's mirrored start ends away from the first fit
    and the others come back: the start with every axis mirrored is ruled
    out (not polished), and the modes are those the search finds when it
    is polished (same starts' labels, log-posteriors within 1e-6)."""
    model, theta = fitted.model, fitted.theta_ls
    _, ruled = modes.search(model, theta)
    assert ruled["ruled_out"] == 1
    monkeypatch.setattr(modes, "_ruled_out", lambda *a: False)
    _, full = modes.search(model, theta)
    assert "ruled_out" not in full
    assert full["starts"] == ruled["starts"] + 1
    kept = {m["start"]: m["log_posterior_difference"] for m in ruled["modes"]}
    for m in full["modes"]:
        if m["start"] in kept:
            assert m["log_posterior_difference"] == pytest.approx(kept[m["start"]], abs=1e-6)
        else:       # the joint start: merged with, or far below, what the single starts found
            assert m["start"] == modes.JOINT and m["mass_fraction"] < 1e-6
