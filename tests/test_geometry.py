"""Geometry: SEED conventions, parametrisations, UVW matrices."""
import numpy as np
import pytest
from scipy.integrate import quad

from bayescal.core.orientation.geometry import (STS2_UVW, TRILLIUM_UVW, Circle, Sphere,
                                                azimuth_dip, tilt_components, tilt_from_vertical,
                                                unit_vector, unwrap_azimuths)


@pytest.mark.parametrize("az,dip,expected", [
    (0, 0, (1, 0, 0)),       # north
    (90, 0, (0, 1, 0)),      # east
    (0, -90, (0, 0, -1)),    # SEED upward vertical: dip -90 points up (NED z is down)
    (0, 90, (0, 0, 1)),
    (45, 0, (np.sqrt(0.5), np.sqrt(0.5), 0)),
])
def test_unit_vector_is_seed_convention(az, dip, expected):
    assert np.allclose(unit_vector(az, dip), expected, atol=1e-12)


def test_seed_eq1_rows():
    a, e = np.radians([10.0, 100.0]), np.radians([3.0, -2.0])
    v = unit_vector(np.degrees(a), np.degrees(e))
    eq1 = np.stack([np.cos(a) * np.cos(e), np.sin(a) * np.cos(e), np.sin(e)], axis=1)
    assert np.allclose(v, eq1)


def test_azimuth_dip_round_trip():
    rng = np.random.default_rng(0)
    az, dip = rng.uniform(0, 360, 200), rng.uniform(-89, 89, 200)
    az2, dip2 = azimuth_dip(unit_vector(az, dip))
    assert np.allclose(az2, az) and np.allclose(dip2, dip)


def test_unwrap_keeps_north_intervals_contiguous():
    s = unwrap_azimuths(np.array([359.6, 359.9, 0.2, 0.6]))
    assert np.allclose(s, [-0.4, -0.1, 0.2, 0.6])
    assert np.allclose(unwrap_azimuths(np.array([2.9, 3.1])), [2.9, 3.1])


def test_tilt_of_near_vertical():
    tilt, toward = tilt_from_vertical(unit_vector(30.0, -89.5))
    assert tilt == pytest.approx(0.5) and toward == pytest.approx(30.0)


def test_sphere_parametrisation_inverse_and_uniform_prior():
    v0 = unit_vector(10.0, -89.9)            # near vertical: must stay well conditioned
    sph = Sphere(v0=v0)
    target = unit_vector(200.0, -88.0)
    p = sph.params(target)
    assert np.allclose(sph.vectors(p[None])[0], target)
    # the prior density integrates to the hemisphere's area (2 pi) only with the
    # correct Jacobian exponent (-3/2)
    area, _ = quad(lambda r: np.exp(sph.log_prior(np.array([[r, 0.0]])))[0] * 2 * np.pi * r, 0, np.inf)
    assert area == pytest.approx(2 * np.pi, rel=1e-6)


def test_circle_angle_is_azimuth_in_horizontal_plane():
    c = Circle(e1=np.array([1.0, 0, 0]), e2=np.array([0, 1.0, 0]))
    v = c.vectors(np.radians([[33.0]]))[0]
    assert azimuth_dip(v)[0] == pytest.approx(33.0)


@pytest.mark.parametrize("m", [STS2_UVW, TRILLIUM_UVW])
def test_uvw_matrices_orthonormal_at_cube_corner(m):
    assert np.allclose(m @ m.T, np.eye(3))
    # every element 54.7356 degrees from vertical, 120 degrees apart in azimuth
    assert np.allclose(np.degrees(np.arccos(m[:, 2])), 54.7356, atol=1e-4)
    az = np.degrees(np.arctan2(m[:, 1], m[:, 0])) % 360
    assert np.allclose(np.sort(np.diff(np.sort(az))), [120, 120])


def test_tilt_components_signed_and_sign_of_axis_irrelevant():
    n, e = tilt_components(unit_vector(0.0, -89.0))        # leaning 1 degree toward north
    assert n == pytest.approx(1.0) and e == pytest.approx(0.0, abs=1e-12)
    n2, e2 = tilt_components(-unit_vector(90.0, -89.5))    # reversed axis, 0.5 toward east
    assert n2 == pytest.approx(0.0, abs=1e-12) and e2 == pytest.approx(0.5)
