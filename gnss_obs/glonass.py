"""GLONASS broadcast orbits and clocks: RK4 integration of the PZ-90 state vector.

GLONASS broadcasts the satellite's position, velocity and luni-solar acceleration in the
rotating PZ-90 frame at the instant ``t_b`` (the record's ``toc_gps_s``, already moved from
UTC(SU) labels to GPS time by the reader). The orbit at ``t`` comes from integrating the
equations of motion in the rotating frame with the central term, J2 and the centrifugal and
Coriolis terms, plus the broadcast constant acceleration (GLONASS ICD 5.1, Appendix A.3.1.2),
with a 4th-order Runge-Kutta scheme and steps of at most `MAX_STEP_S`.

The clock is ``δt = -τ_n + γ_n (t - t_b)`` (RINEX stores ``-τ_n`` as the clock bias and
``+γ_n`` as the relative frequency bias). The relativistic effect is already inside τ_n.
PZ-90.11 and WGS-84 agree to a few centimetres; the difference is not applied.

References
----------
GLONASS ICD, edition 5.1 (2008), Appendix A.3.1.2; RINEX 3.04 Table A10.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import A_GLO_M, GM_GLO, J2_GLO, OMEGA_E_GLO
from gnss_obs.kepler import Records, SatelliteStates

__all__ = ["MAX_STEP_S", "glonass_acceleration", "glonass_states"]

Array = npt.NDArray[np.float64]

#: Largest RK4 step, s (the ICD recommends steps of up to a few minutes; 60 s keeps the
#: integration error below a millimetre over the ±15 min validity of a record).
MAX_STEP_S = 60.0


def glonass_acceleration(r_e: Array, v_e: Array, a_ls_e: Array) -> Array:
    """Acceleration of a GLONASS satellite in the rotating PZ-90 frame.

    Parameters
    ----------
    r_e : ndarray, shape (N, 3)
        Position in PZ-90 (≈ ECEF), m.
    v_e : ndarray, shape (N, 3)
        Velocity relative to the rotating frame, m/s.
    a_ls_e : ndarray, shape (N, 3)
        Broadcast luni-solar acceleration, m/s² (constant over a record).

    Returns
    -------
    ndarray, shape (N, 3)
        Acceleration relative to the rotating frame, m/s² (ICD 5.1 eq. A.3.1.2).
    """
    x, y, z = r_e[:, 0], r_e[:, 1], r_e[:, 2]
    r2 = np.einsum("ni,ni->n", r_e, r_e)
    r = np.sqrt(r2)
    mu_r3 = GM_GLO / (r2 * r)
    j2 = 1.5 * J2_GLO * GM_GLO * A_GLO_M ** 2 / (r2 * r2 * r)
    z2_r2 = z * z / r2
    w2 = OMEGA_E_GLO ** 2
    ax = -mu_r3 * x - j2 * x * (1.0 - 5.0 * z2_r2) + w2 * x + 2.0 * OMEGA_E_GLO * v_e[:, 1]
    ay = -mu_r3 * y - j2 * y * (1.0 - 5.0 * z2_r2) + w2 * y - 2.0 * OMEGA_E_GLO * v_e[:, 0]
    az = -mu_r3 * z - j2 * z * (3.0 - 5.0 * z2_r2)
    return np.stack([ax, ay, az], axis=-1) + a_ls_e


def _derivative(state: Array, a_ls_e: Array) -> Array:
    return np.concatenate([state[:, 3:], glonass_acceleration(state[:, :3], state[:, 3:], a_ls_e)],
                          axis=-1)


def glonass_states(records: Records, t_gps_s: npt.ArrayLike, *,
                   max_step_s: float = MAX_STEP_S) -> SatelliteStates:
    """Satellite states from GLONASS broadcast records, one record per requested time.

    Parameters
    ----------
    records : Records, N rows
        GLONASS records of `read_rinex_nav` (``toc_gps_s``, ``clock_bias_s``, ``gamma_n``,
        ``x_m``... ``vz_mps``, ``ax_mps2``... ``az_mps2``); row k is used at ``t_gps_s[k]``.
    t_gps_s : array_like, shape (N,)
        GPS time of each evaluation, s since the GPS epoch.
    max_step_s : float
        Largest integration step, s; every row takes the same number of steps.

    Returns
    -------
    SatelliteStates
        ``relativity_s`` is zero (contained in τ_n).
    """
    t = np.asarray(t_gps_s, dtype=float)
    def cols(names: str) -> Array:
        return np.stack([np.asarray(records[n], dtype=float) for n in names.split()], axis=-1)

    state = cols("x_m y_m z_m vx_mps vy_mps vz_mps")
    a_ls_e = cols("ax_mps2 ay_mps2 az_mps2")
    if t.shape != state.shape[:1]:
        raise ValueError(f"t_gps_s must have shape {state.shape[:1]}, got {t.shape}")
    dt = t - np.asarray(records["toc_gps_s"], dtype=float)
    n_steps = int(np.ceil(np.max(np.abs(dt), initial=0.0) / max_step_s))
    if n_steps > 0:
        h = (dt / n_steps)[:, None]
        for _ in range(n_steps):
            k1 = _derivative(state, a_ls_e)
            k2 = _derivative(state + 0.5 * h * k1, a_ls_e)
            k3 = _derivative(state + 0.5 * h * k2, a_ls_e)
            k4 = _derivative(state + h * k3, a_ls_e)
            state = state + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    gamma = np.asarray(records["gamma_n"], dtype=float)
    clock = np.asarray(records["clock_bias_s"], dtype=float) + gamma * dt
    return SatelliteStates(r_e=state[:, :3], v_e=state[:, 3:], clock_s=clock,
                           clock_drift_sps=gamma.copy(), relativity_s=np.zeros_like(t))
