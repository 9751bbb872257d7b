"""Earth and transport rates against the rotation of C_n_e computed by finite differences."""
from __future__ import annotations

import casadi as ca
import numpy as np

from strapdown.backend import batch_call
from strapdown.euler import skew
from strapdown.frames import omega_en_n, omega_ie_n, radii_of_curvature
from trackmodel.earth import WGS84, C_n_e, radii, sphere

ATOL_RADII_M = 1e-6            # the same closed form, two backends
STEP_S = 1e-3                  # central difference in time
ATOL_RATE_RADPS = 1e-12        # truncation (v/R)^3 dt^2 ~ 1e-25, rounding 1e-16/1e-3


def test_casadi_radii_equal_trackmodel():
    lat = np.radians(np.linspace(-89, 89, 41))
    sym = ca.SX.sym("lat")
    fn = ca.Function("r", [sym], [ca.vertcat(*radii_of_curvature(sym, earth=WGS84))])
    (out,) = batch_call(fn, lat[:, None])
    np.testing.assert_allclose(out, np.stack(radii(lat, earth=WGS84), axis=-1), atol=ATOL_RADII_M)


def test_earth_rate_is_the_polar_axis_in_enu():
    lat, lon = np.radians(52.3), np.radians(13.1)
    expected = C_n_e(lat, lon).T @ np.array([0, 0, WGS84.omega_radps])
    np.testing.assert_allclose(omega_ie_n(lat), expected, atol=1e-20)


def test_transport_rate_rotates_the_enu_frame(rng):
    """dC_n_e/dt = C_n_e [ω_en_n ×] for a point moving with v_n (geodetic kinematics)."""
    for earth in (WGS84, sphere()):
        for _ in range(20):
            lat, lon, h = rng.uniform(-1.4, 1.4), rng.uniform(-3, 3), rng.uniform(-100, 3000)
            v_n = rng.uniform(-300, 300, size=3)
            R_M, R_N = radii(lat, earth=earth)
            lat_dot, lon_dot = v_n[1] / (R_M + h), v_n[0] / ((R_N + h) * np.cos(lat))
            dC = (C_n_e(lat + lat_dot * STEP_S, lon + lon_dot * STEP_S)
                  - C_n_e(lat - lat_dot * STEP_S, lon - lon_dot * STEP_S)) / (2 * STEP_S)
            w = omega_en_n(v_n, lat, h, earth=earth)
            np.testing.assert_allclose(dC, C_n_e(lat, lon) @ skew(w), atol=ATOL_RATE_RADPS)
