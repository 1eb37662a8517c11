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
