"""The catalogue of effects (bayescal.criticism.effects): each effect
implements the interface of effects.base, and its factor nests the base
model (1 at the effect's null value) with the closed form its docstring
states."""
import numpy as np
import pytest

from bayescal.criticism.effects import (CATALOGUE, CriticismEffect, ExtraPole, GainError,
                                        TimingOffset)


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_every_effect_implements_the_interface(name):
    cls = CATALOGUE[name]
    assert issubclass(cls, CriticismEffect) and cls.name == name
    for method in ("factor", "log_prior", "physical", "explain"):
        assert getattr(cls, method) is not getattr(CriticismEffect, method), (name, method)


def test_factors_are_one_at_the_null_value_and_the_closed_form_elsewhere():
    f = np.array([0.1, 1.0, 3.0])
    null = np.zeros((1, 1))
    for effect in (TimingOffset([0]), ExtraPole([0], "sut"), ExtraPole([0], "ref"),
                   GainError(0)):
        np.testing.assert_allclose(np.broadcast_to(effect.factor(f, null), (1, 1, 3)), 1.0,
                                   atol=1e-15)
    # a clock 0.25 s late: the factor undoes the phase -2 pi f tau
    np.testing.assert_allclose(TimingOffset([0]).factor(f, np.array([[0.25]]))[0, 0],
                               np.exp(2j * np.pi * f * 0.25), rtol=1e-15)
    # a missing pole at 0.5 Hz (1 / corner = 2 s), unit gain at 1 Hz
    x = 2.0
    want = (1 + 1j * f * x) / abs(1 + 1j * x)
    np.testing.assert_allclose(ExtraPole([0], "sut").factor(f, np.array([[x]]))[0, 0], want,
                               rtol=1e-15)
    np.testing.assert_allclose(ExtraPole([0], "ref").factor(f, np.array([[x]]))[0, 0],
                               1 / want, rtol=1e-15)
    # a sensitivity 10 % high: the factor divides by 1.1
    np.testing.assert_allclose(GainError(0).factor(f, np.array([[0.1]]))[0, 0], 1 / 1.1,
                               rtol=1e-15)


def test_default_absence_is_every_parameter():
    assert TimingOffset([0]).absence == (0,)
    assert CATALOGUE["clock_drift"].absence == (1,)       # its rate, not its offset
