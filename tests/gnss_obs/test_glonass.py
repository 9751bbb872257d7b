"""GLONASS orbits: RK4 in the rotating frame against an inertial-frame integration."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gnss_obs.constants import A_GLO_M, GM_GLO, J2_GLO, OMEGA_E_GLO
from gnss_obs.glonass import glonass_states

#: RK4 with 60-s steps over ±15 min: the ICD's recommended integration is accurate to well
#: below a centimetre; 1 cm and 10 µm/s leave room for the solve_ivp tolerance (rtol 1e-12).
ATOL_POS_M = 1e-2
ATOL_VEL_MPS = 1e-5
ATOL_CLOCK_S = 1e-15


def _rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _inertial_reference(rec, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Integrate in inertial axes aligned with PZ-90 at t_b: central + J2 gravity and the
    broadcast luni-solar acceleration (fixed in the rotating frame, so turning with it).
    No centrifugal or Coriolis term: an independent formulation of ICD 5.1 A.3.1.2."""
    r0 = np.array([rec.x_m, rec.y_m, rec.z_m])
    v0 = np.array([rec.vx_mps, rec.vy_mps, rec.vz_mps])
    a_ls = np.array([rec.ax_mps2, rec.ay_mps2, rec.az_mps2])
    w = np.array([0.0, 0.0, OMEGA_E_GLO])

    def f(t, y):
        r = y[:3]
        rn = np.linalg.norm(r)
        k = 1.5 * J2_GLO * GM_GLO * A_GLO_M ** 2 / rn ** 5
        z2 = (r[2] / rn) ** 2
        g = -GM_GLO / rn ** 3 * r - k * r * np.array([1 - 5 * z2, 1 - 5 * z2, 3 - 5 * z2])
        return np.r_[y[3:], g + _rot(OMEGA_E_GLO * t) @ a_ls]

    sol = solve_ivp(f, (0.0, dt), np.r_[r0, v0 + np.cross(w, r0)], method="DOP853",
                    rtol=1e-12, atol=1e-9)
    r_i, v_i = sol.y[:3, -1], sol.y[3:, -1]
    R = _rot(OMEGA_E_GLO * dt).T
    return R @ r_i, R @ (v_i - np.cross(w, r_i))


@pytest.mark.parametrize("dt", [-900.0, -60.0, 0.0, 37.0, 900.0])
def test_rk4_matches_inertial_integration(nav, dt):
    rec = nav.records["R"].iloc[3]
    s = glonass_states(nav.records["R"].iloc[[3]], [rec.toc_gps_s + dt])
    r_ref, v_ref = _inertial_reference(rec, dt)
    np.testing.assert_allclose(s.r_e[0], r_ref, rtol=0, atol=ATOL_POS_M)
    np.testing.assert_allclose(s.v_e[0], v_ref, rtol=0, atol=ATOL_VEL_MPS)


def test_clock_is_minus_tau_plus_gamma_dt(nav):
    """RINEX stores -τn and +γn: δt = -τn + γn (t - t_b) (GLONASS ICD 5.1 §3.3.3)."""
    recs = nav.records["R"].iloc[:5]
    dt = np.array([-600.0, 0.0, 120.0, 450.0, 899.0])
    s = glonass_states(recs, recs["toc_gps_s"].to_numpy() + dt)
    expected = -recs["tau_n_s"].to_numpy() + recs["gamma_n"].to_numpy() * dt
    np.testing.assert_allclose(s.clock_s, expected, rtol=0, atol=ATOL_CLOCK_S)
    assert np.all(s.relativity_s == 0.0)
