r"""IMU scale factors and misalignments the filter does not estimate, as steps of its biases.

An IMU triad reads ``(I + S + M) x + b`` (`strapdown.imu_errors`: scale factors ``S``,
misalignments ``M``, constants of the run). The filter estimates biases only. Its bias
states absorb ``(S + M) x₀`` for the static part of the input (gravity, the Earth's rate)
once GNSS has observed them, but when the kinematic part ``x_d`` changes — a curve's
centripetal acceleration ``v² κ`` and yaw rate ``v κ``, a vertical curve's ``v² ϑ'`` and
pitch rate ``v ϑ'`` — the effective bias ``b + (S + M) x_d`` steps with it, by
``(S + M) Δx_d``: axis ``i`` by a zero-mean error of variance

``σ_sf² Δx_{d,i}² + σ_m² Σ_{j≠i} Δx_{d,j}²``,

which the random walk of the bias (``2σ_GM²/τ`` per second) cannot follow. At 100 m/s on
a 100-m circle the tactical grade's 0.2-mrad misalignment puts 0.02 m/s² of the 10-g
centripetal acceleration on the along-track axis at the entry, against a bias σ of 2e-4
m/s²: NEES 190 for 7 states with the grade's scale factors and misalignments, 9 without.

`bias_step_densities` gives the bias states that variance as process noise, per IMU step,
from the track's kinematic input at the predicted path (lateral and normal components of
``v² du/ds`` and the rates ``v du/ds``, body y ≈ left and z ≈ up of the track frame): the
variance of a change of ``x²``, ``σ² |Δ(x²)|``, summed over the steps of a monotonic change
from 0 to ``X``, is ``σ² X²``, exactly the variance of the bias step whether the change
takes one step (an arc without transition) or a whole clothoid. A curve's exit adds as
much again although the true bias returns to its value before the curve: the filter is
conservative there, not overconfident. The along-track acceleration (traction and
braking, ≲ 1 m/s²) is left out: its share is below the bias instability of every grade.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.imu_errors import ImuErrors
from strapdown.reduced import TRACK_PARAMETER_NAMES, cross_track_basis

__all__ = ["bias_step_densities", "kinematic_inputs"]

Array = npt.NDArray[np.float64]

_U = slice(TRACK_PARAMETER_NAMES.index("u_E"), TRACK_PARAMETER_NAMES.index("u_U") + 1)
_DU = slice(TRACK_PARAMETER_NAMES.index("du_E_ds"), TRACK_PARAMETER_NAMES.index("du_U_ds") + 1)
_PPM = 1e-6


def kinematic_inputs(params: Array, speed_mps: float) -> tuple[Array, Array]:
    """The track's kinematic specific force and angular rate in body axes (x forward,
    y left, z up), at the track parameters `params` (N, 16) and a speed (m/s).

    Returns
    -------
    f_d : ndarray, shape (N, 3)
        ``[0, v² l·du/ds, v² n·du/ds]``, m/s².
    omega_d : ndarray, shape (N, 3)
        ``[0, −v n·du/ds, v l·du/ds]`` (pitch and yaw rate), rad/s.
    """
    lateral, normal = cross_track_basis(params[:, _U])
    du = params[:, _DU]
    k_l = np.einsum("ni,ni->n", lateral, du)
    k_n = np.einsum("ni,ni->n", normal, du)
    zero = np.zeros_like(k_l)
    v = float(speed_mps)
    return (np.column_stack([zero, v * v * k_l, v * v * k_n]),
            np.column_stack([zero, -v * k_n, v * k_l]))


def _axis_variances(change_sq: Array, sigma_sf: float, sigma_m: float) -> Array:
    """``σ_sf² c_i + σ_m² Σ_{j≠i} c_j`` for ``c = |Δ(x²)|`` (N, 3)."""
    total = change_sq.sum(axis=1, keepdims=True)
    return sigma_sf ** 2 * change_sq + sigma_m ** 2 * (total - change_sq)


def bias_step_densities(params_prev: Array, params: Array, speed_mps: float, imu: ImuErrors,
                        step_s: Array) -> Array | None:
    """Extra densities of the six bias random walks for each step (module docstring).

    Parameters
    ----------
    params_prev : ndarray, shape (16,)
        Track parameters at the sample before the first.
    params : ndarray, shape (M, 16)
        At the samples.
    speed_mps : float
    imu : ImuErrors
        The grade the filter assumes (its scale-factor and misalignment σ).
    step_s : ndarray, shape (M,)
        Length of the step that starts at each sample, s (> 0).

    Returns
    -------
    ndarray, shape (M, 6) or None
        ``[b_ax, b_ay, b_az, b_gx, b_gy, b_gz]`` densities, (m/s²)²/s and (rad/s)²/s, the
        change between sample ``k − 1`` and ``k`` given to the step from ``k``; None when
        the grade has no scale factor or misalignment, or the input does not change.
    """
    sf_a, sf_g = imu.accel_scale_factor_ppm * _PPM, imu.gyro_scale_factor_ppm * _PPM
    m_a, m_g = imu.accel_misalignment_rad, imu.gyro_misalignment_rad
    if sf_a == sf_g == m_a == m_g == 0.0:
        return None
    f_d, w_d = kinematic_inputs(np.vstack([params_prev[None, :], params]), speed_mps)
    d_f, d_w = np.abs(np.diff(f_d ** 2, axis=0)), np.abs(np.diff(w_d ** 2, axis=0))
    if not (d_f.any() or d_w.any()):
        return None
    variance = np.hstack([_axis_variances(d_f, sf_a, m_a), _axis_variances(d_w, sf_g, m_g)])
    return variance / np.asarray(step_s, dtype=float)[:, None]
