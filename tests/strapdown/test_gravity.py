"""Normal gravity against independent references: the gradient of the normal potential
(zonal harmonics J2..J6 + centrifugal) and point-mass gravitation + centrifugal in ECEF."""
from __future__ import annotations

import numpy as np
import pytest

from strapdown.errors import StrapdownError
from strapdown.gravity import g_n
from trackmodel.earth import WGS84, C_n_e, Ellipsoid, geodetic_to_ecef, sphere

# Even zonal coefficients of the WGS-84 normal potential, J_2n = -sqrt(4n+1) C̄_2n,0 with
# C̄_20 = -0.484166774985e-3, C̄_40 = 0.790303733511e-6, C̄_60 = -0.168724961151e-8
# (NIMA TR8350.2 §5.1).
J_NORMAL = {2: 1.08262998905e-3, 4: -0.237091222e-5, 6: 0.608347e-8}
# The reference neglects J8 (~1e-11) and the code the plumb-line curvature
# (~8e-6 m/s² per km of height) and the h³ term: 2e-5 m/s² covers both up to 1 km.
ATOL_WGS84_MPS2 = 2e-5
# The sphere formula is exact; rounding of GM/r² (~1e-15 relative).
ATOL_SPHERE_MPS2 = 1e-12
FD_STEP_M = 1.0


def _legendre(n: int, x: np.ndarray) -> np.ndarray:
    p0, p1 = np.ones_like(x), x
    for k in range(1, n):
        p0, p1 = p1, ((2 * k + 1) * x * p1 - k * p0) / (k + 1)
    return p1


def _normal_potential(r_e: np.ndarray) -> np.ndarray:
    """Gravitational potential of the normal field plus the centrifugal potential."""
    r = np.linalg.norm(r_e, axis=-1)
    sin_phi_c = r_e[..., 2] / r
    series = sum(j * (WGS84.a_m / r) ** n * _legendre(n, sin_phi_c) for n, j in J_NORMAL.items())
    rho2 = r_e[..., 0] ** 2 + r_e[..., 1] ** 2
    return WGS84.gm_m3ps2 / r * (1 - series) + 0.5 * WGS84.omega_radps ** 2 * rho2


@pytest.mark.parametrize("h", [0.0, 500.0, 1000.0])
def test_wgs84_normal_gravity_is_the_potential_gradient(h):
    lat = np.radians(np.linspace(-89.0, 89.0, 37))
    lon = np.radians(np.linspace(-170.0, 170.0, 37))
    r_e = geodetic_to_ecef(lat, lon, h, earth=WGS84)
    grad = np.stack([(_normal_potential(r_e + FD_STEP_M * e) - _normal_potential(r_e - FD_STEP_M * e))
                     / (2 * FD_STEP_M) for e in np.eye(3)], axis=-1)
    ref_n = np.einsum("...ji,...j->...i", C_n_e(lat, lon), grad)
    np.testing.assert_allclose(g_n(lat, h, earth=WGS84), ref_n, atol=ATOL_WGS84_MPS2)


def test_sphere_gravity_is_gravitation_plus_centrifugal_in_ecef():
    """Erratum 4: north centrifugal component is −Ω²r cosφ sinφ (checked in ECEF)."""
    earth = sphere()
    lat = np.radians(np.linspace(-80.0, 80.0, 17))
    lon = np.radians(np.linspace(0.0, 300.0, 17))
    h = np.linspace(-100.0, 2000.0, 17)
    r_e = geodetic_to_ecef(lat, lon, h, earth=earth)
    r = np.linalg.norm(r_e, axis=-1, keepdims=True)
    omega_e = np.array([0.0, 0.0, earth.omega_radps])
    g_e = -earth.gm_m3ps2 * r_e / r ** 3 - np.cross(omega_e, np.cross(omega_e, r_e))
    ref_n = np.einsum("...ji,...j->...i", C_n_e(lat, lon), g_e)
    np.testing.assert_allclose(g_n(lat, h, earth=earth), ref_n, atol=ATOL_SPHERE_MPS2)
    assert np.all(g_n(lat[lat > 0], 0.0, earth=earth)[:, 1] < 0)


def test_other_ellipsoid_is_refused():
    with pytest.raises(StrapdownError, match="normal-gravity"):
        g_n(0.1, 0.0, earth=Ellipsoid("other", 6_378_000.0, 1 / 300.0))
