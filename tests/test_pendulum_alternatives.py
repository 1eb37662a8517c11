"""One pendulum per model (bayescal.criticism.search.PENDULUM_ALTERNATIVES):
the SUT's period and damping under the sensor's stated prior
(``response_parameters``) and its corner under the wide prior
(``sut_corner``) each replace the metadata's pendulum, so a model holding
one is never offered the other."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from bayescal.core.priors import Priors
from bayescal.core.response import TwoPoleFamily
from bayescal.criticism import search


def _model(effects=()):
    fam = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                        gain_units="counts/(m/s)")
    blocks = [SimpleNamespace(family=fam, free="gain", channel_id=f"XX.S..BH{c}")
              for c in "12Z"]
    return SimpleNamespace(spectra=SimpleNamespace(n_u=3, band_edges=np.array([0.02, 1.0]),
                                                           block_totals=None),
                           blocks=blocks, priors=Priors(), effects=list(effects))


def _offered(effects):
    m = _model(effects)
    return [key for key, _, _ in search._candidates(m, "gain", m.effects)]


def test_a_model_with_one_pendulum_is_not_offered_the_other():
    """Held two-pole channels are offered both pendulums; a model holding
    either is offered neither (the other poles and the delay stay)."""
    both = _offered([])
    assert {"response_parameters", "sut_corner"} <= set(both), both
    for held in ("response_parameters", "sut_corner"):
        effect = SimpleNamespace(name=held)
        got = _offered([effect])
        assert not {"response_parameters", "sut_corner"} & set(got), (held, got)
        assert {"timing_offset", "extra_pole:sut", "extra_pole:ref"} <= set(got), got


def test_a_released_pendulum_is_given_back():
    """``released`` holds fitted pendulums at gain only for a corner to take
    them up; ``restored`` (used when that corner is dropped) gives the
    blocks back their pendulum: at a theta whose orientation and log gains
    moved, the round trip keeps those and takes the response parameters
    from the search's start, and the restored model's likelihood is the
    start model's own at that theta."""
    from bayescal.core.fit.run import build_model
    from bayescal.criticism.effects import TimingOffset
    from bayescal.io.align import align
    from bayescal.core.spectra.welch import cross_spectra
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=600, fs=4, seed=1)
    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
    sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), (0.05, 1.0))
    base = build_model(sp, r.vectors, s.vectors, s.families(), free="all").model
    start = np.array([0.01, -0.02, 0.03, -0.04, np.log(760.0)] * 3)
    base.estimate_noise(start)
    effect = TimingOffset([0, 1, 2])
    model = search.with_effects(base, [effect])
    held, th = search.released(model, np.r_[start, 0.01], [0, 1, 2])
    assert [b.free for b in held.blocks] == ["gain"] * 3 and th.size == 3 * 3 + 1
    moved = th + 0.005
    back, th2 = search.restored(held, moved, base, start)
    assert [b.free for b in back.blocks] == ["all"] * 3
    want = start.copy().reshape(3, 5)
    want[:, [0, 1, 4]] = moved[:9].reshape(3, 3)
    np.testing.assert_allclose(th2, np.r_[want.ravel(), moved[-1]])
    np.testing.assert_allclose(back.log_likelihood(th2[None]),
                               model.log_likelihood(th2[None]), rtol=1e-12)
