"""Every model bayescal fits (pair, errors-in-variables, coil run, random,
step and sine, and each UVW element's run model) offers the one interface
of :class:`bayescal.core.model.protocol.PosteriorModel`, with the shapes it
promises, and its whitened residual is the likelihood: ``-log L`` equals
its squared norm times the model's ``LIKELIHOOD_SCALE``."""
from __future__ import annotations

import numpy as np
import pytest

from bayescal import coil
from bayescal.coil.random import PZModel
from bayescal.coil.hf import PZSpec
from bayescal.coil.sine import SineModel
from bayescal.coil.step import least_squares_step
from bayescal.coil.timedomain import Predictor, checked_arrays, coil_transfer, padding
from bayescal.core.model.eiv import EIVModel
from bayescal.core.model.likelihood import ChannelBlock, Model
from bayescal.core.model.protocol import PosteriorModel
from bayescal.core.orientation.geometry import STS2_UVW, Sphere
from bayescal.core.spectra.welch import cross_spectra
from bayescal.io.align import align
from bayescal.simulate.cal import simulate_random_cal, simulate_sine_cal, simulate_step_cal
from bayescal.simulate.coil import simulate_calibration
from bayescal.simulate.pair import simulate_pair

COIL = 1e-9


def _pair(eiv):
    sim = simulate_pair(duration=1800, fs=5, seed=3)
    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
    sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), (0.03, 1.0))
    blocks = [ChannelBlock(str(i), Sphere(v0=v), f, "all")
              for i, (v, f) in enumerate(zip(s.vectors, s.families()))]
    theta = np.concatenate([np.r_[b.manifold.params(b.manifold.v0), 1.0, 1.0,
                                  np.log(b.family.gain)] for b in blocks])
    model = (EIVModel(sp, r.vectors, blocks, ref_noise="equal") if eiv
             else Model(sp, r.vectors, blocks))
    return model, theta


def _one_output(sim):
    return coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")


def _random():
    run = _one_output(simulate_random_cal(duration=1800, fs=5, seed=1))
    spec = PZSpec.from_response(run.responses[0], "lp", 0.5)
    sp = coil.run_spectra(run, COIL, (0.005, 0.5))
    return PZModel(sp, spec), spec.nominal_theta()


def _uvw_element():
    sim = simulate_calibration(seed=2, duration=3600.0)
    run = coil.read_run("W", sim.runs["W"], sim.inventory, "BC0", "cal_W")
    sp = coil.run_spectra(run, COIL, (0.005, 0.1), nperseg=1024)
    model = coil.RunModel(sp, run.coefficients(STS2_UVW), run.families, run.families[-1])
    return model, np.array([1.0, 1.0, np.log(run.families[-1].gain)])


def _step():
    run = _one_output(simulate_step_cal(duration=1200.0, fs=5.0,
                                        steps=((120.0, 1.0), (600.0, 0.0)), seed=1))
    model, _, theta, _ = least_squares_step(run, COIL)
    return model, theta


def _sine():
    run = _one_output(simulate_sine_cal(0.05, duration=900.0, fs=5.0, seed=1))
    x, u = checked_arrays(run)
    pred = Predictor(u - u.mean(), run.fs, coil_transfer(run, COIL),
                     padding(run.families[0], run.fs))
    return SineModel(x, run.fs, pred, skip=100), np.array([0.0, 0.0])


BUILDERS = {"pair": lambda: _pair(False), "pair EIV": lambda: _pair(True), "random": _random,
            "UVW element": _uvw_element, "step": _step, "sine": _sine}


@pytest.mark.parametrize("kind", list(BUILDERS))
def test_every_model_offers_the_one_interface(kind):
    model, theta = BUILDERS[kind]()
    assert isinstance(model, PosteriorModel)
    assert len(model.names) == model.ndim == theta.size
    lo, hi = model.bounds()
    assert lo.shape == hi.shape == (model.ndim,) and np.all(lo < hi)
    model.estimate_noise(theta)
    walkers = np.stack([theta, theta * (1 + 1e-4)])
    lp = model.log_prob(walkers)
    assert lp.shape == (2,) and np.all(np.isfinite(lp))
    r = model.likelihood_residual(theta)
    assert r.ndim == 1 and np.isrealobj(r) and np.all(np.isfinite(r))
    # the whitened residual is the likelihood: -log L = scale * |r|^2
    scale = getattr(model, "LIKELIHOOD_SCALE", 1.0)
    log_like = lp[0] - model.log_prior(theta[None])[0]
    np.testing.assert_allclose(-log_like, scale * r @ r, rtol=1e-9)


def test_an_object_without_the_interface_is_refused():
    class NoNoise:
        names, ndim = ("a",), 1

        def bounds(self):
            return np.zeros(1), np.ones(1)

        def log_prob(self, theta):
            return np.zeros(len(theta))

        def likelihood_residual(self, theta):
            return np.zeros(1)

    assert not isinstance(NoNoise(), PosteriorModel)
