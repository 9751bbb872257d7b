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

The elements of ``S + M`` that the constrained filter carries as states
(`railnav.filters.constrained_model.SCALE_ELEMENTS`: the accelerometer's ``M_zy``, the
gyro's ``S_zz``) are left out of that sum (``estimated=``): the state steps
with the measured input, at the truth's crossing.

`bias_step_densities` gives the bias states that variance as process noise, per IMU step,
from the track's kinematic input at the predicted path (lateral and normal components of
``v² du/ds`` and the rates ``v du/ds``, body y ≈ left and z ≈ up of the track frame): the
variance of a change of ``x²``, ``σ² |Δ(x²)|``, summed over the steps of a monotonic change
from 0 to ``X``, is ``σ² X²``, exactly the variance of the bias step whether the change
takes one step (an arc without transition) or a whole clothoid. A curve's exit adds as
much again although the true bias returns to its value before the curve: the filter is
conservative there, not overconfident.

The along-track specific force's steps (traction, braking, the grade's share of gravity)
are `railnav.filters.along_force_steps`'s.

**When, along the predicted path.** The IMU sees the step when the *true* train crosses
the joint; the filter's predicted path crosses it up to a few σ_s earlier or later. Given
at the predicted crossing only, the variance comes one or more samples late whenever the
estimate is behind the truth, and the pseudo-observation of those samples, which already
carries the true ``(S + M) Δx_d``, is explained by the attitude at the bias's old, tiny
σ: at 100 m/s on R 100 m (tactical, seed 2) the roll σ fell from 0.45 mrad to 13 µrad in
the entry's first sample while the roll error stayed at 0.23 mrad (NEES 188 for 7 states;
the grade's accelerometer misalignment alone: roll z² 141, no scale factor or
misalignment: NEES 12). The filter therefore gives the steps over the prior of ``s``
(`step_nodes`: the predicted path shifted by a 5-point Gauss–Hermite rule in σ_s, each
path's steps weighted by its node's weight), so that the bias variance grows as the
probability that the truth has crossed, the total still ``σ² X²``. Giving it all 3σ_s
early instead (a lead) overshoots: the bias then loosens on the straight, where the
pseudo-observation ties it again before the truth's step (seed 2: NEES 18 with a 3σ lead,
39 with 6σ; 11-12 spread).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.imu_errors import ImuErrors
from strapdown.reduced import TRACK_PARAMETER_NAMES, cross_track_basis

__all__ = ["bias_step_densities", "path_bias_step_densities", "weighted_path_densities",
           "kinematic_inputs", "step_nodes"]

Array = npt.NDArray[np.float64]

_U = slice(TRACK_PARAMETER_NAMES.index("u_E"), TRACK_PARAMETER_NAMES.index("u_U") + 1)
_DU = slice(TRACK_PARAMETER_NAMES.index("du_E_ds"), TRACK_PARAMETER_NAMES.index("du_U_ds") + 1)
_PPM = 1e-6
_AXES = ("x", "y", "z")
#: Gauss–Hermite nodes (in σ_s) and weights of the steps' spread (module docstring).
_GH_X, _GH_W = np.polynomial.hermite_e.hermegauss(5)
_GH_W = _GH_W / _GH_W.sum()


def step_nodes(sigma_s_m: float) -> list[tuple[float, float]]:
    """Offsets (m) and weights of the paths along which the steps are given: the prior
    of ``s`` by a 5-point Gauss–Hermite rule (one path, offset 0, when σ_s is 0)."""
    sigma = max(float(sigma_s_m), 0.0)
    if sigma == 0.0:
        return [(0.0, 1.0)]
    return [(float(sigma * x), float(w)) for x, w in zip(_GH_X, _GH_W)]


def kinematic_inputs(params: Array, speed_mps: float, along_mps2=None
                     ) -> tuple[Array, Array]:
    """The track's kinematic specific force and angular rate in body axes (x forward,
    y left, z up), at the track parameters `params` (N, 16) and a speed (m/s; scalar or
    one per row, (N,)); with
    `along_mps2` (scalar or (N,)), the along-track acceleration as the x component.

    Returns
    -------
    f_d : ndarray, shape (N, 3)
        ``[a, v² l·du/ds, v² n·du/ds]``, m/s² (``a`` 0 without `along_mps2`).
    omega_d : ndarray, shape (N, 3)
        ``[0, −v n·du/ds, v l·du/ds]`` (pitch and yaw rate), rad/s.
    """
    lateral, normal = cross_track_basis(params[:, _U])
    du = params[:, _DU]
    k_l = np.einsum("ni,ni->n", lateral, du)
    k_n = np.einsum("ni,ni->n", normal, du)
    zero = np.zeros_like(k_l)
    along = zero if along_mps2 is None else np.broadcast_to(
        np.asarray(along_mps2, dtype=float), k_l.shape)
    v = float(speed_mps) if np.ndim(speed_mps) == 0 else np.asarray(speed_mps, dtype=float)
    return (np.column_stack([along, v * v * k_l, v * v * k_n]),
            np.column_stack([zero, -v * k_n, v * k_l]))


def _axis_variances(change_sq: Array, sigma_sf: float, sigma_m: float) -> Array:
    """``σ_sf² c_i + σ_m² Σ_{j≠i} c_j`` for ``c = |Δ(x²)|`` (..., 3)."""
    total = change_sq.sum(axis=-1, keepdims=True)
    return sigma_sf ** 2 * change_sq + sigma_m ** 2 * (total - change_sq)


def _leave_out(variance: Array, changes: tuple[Array, Array], sigmas: tuple,
               estimated: tuple) -> None:
    """Subtract, in place, the share ``σ² c_j`` of each estimated element ``(i, j)`` from
    row ``i``'s variance (`variance` (..., 6): accelerometer then gyro; `changes` each
    triad's ``c = |Δ(x²)|`` (..., 3); `sigmas` each triad's ``(σ_sf, σ_m)``), floored
    at 0 (the rounding of `_axis_variances`' sum)."""
    for triad, (change, (sigma_sf, sigma_m), elements) in enumerate(
            zip(changes, sigmas, estimated)):
        for element in elements:
            i, j = _AXES.index(element[0]), _AXES.index(element[1])
            sigma = sigma_sf if i == j else sigma_m
            column = variance[..., 3 * triad + i]
            column -= sigma * sigma * change[..., j]
            np.maximum(column, 0.0, out=column)


def bias_step_densities(params_prev: Array, params: Array, speed_mps: float, imu: ImuErrors,
                        step_s: Array, *, estimated: tuple = ((), ())) -> Array | None:
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
    estimated : (tuple of str, tuple of str)
        The accelerometer's and the gyro's elements ``"<row><column>"`` of ``S + M`` that
        the filter carries as states
        (`railnav.filters.constrained_model.scale_elements_for`): their share of a step,
        ``σ² |Δ(x_column²)|`` on the row's bias, is left out.

    Returns
    -------
    ndarray, shape (M, 6) or None
        ``[b_ax, b_ay, b_az, b_gx, b_gy, b_gz]`` densities, (m/s²)²/s and (rad/s)²/s, the
        change between sample ``k − 1`` and ``k`` given to the step from ``k``; None when
        the grade has no scale factor or misalignment, or the input does not change.
    """
    found = path_bias_step_densities(np.asarray(params_prev)[None, :],
                                     np.asarray(params)[None, :, :], speed_mps, imu, step_s,
                                     estimated=estimated)
    return None if found is None or not found[1][0] else found[0][0]


def path_bias_step_densities(params_prev: Array, params: Array, speed_mps: float,
                             imu: ImuErrors, step_s: Array, *, estimated: tuple = ((), ())
                             ) -> tuple[Array, Array] | None:
    """`bias_step_densities` of P paths over the same steps at once (the spread's paths,
    `step_nodes`): one `kinematic_inputs` call on all their rows (pure per row: the same
    numbers as path by path).

    Parameters
    ----------
    params_prev : ndarray, shape (P, 16)
        Each path's track parameters at the sample before the first.
    params : ndarray, shape (P, M, 16)
        At the samples.
    speed_mps : float or ndarray, shape (P,)
        The speed, or each path's (paths of several hypotheses).
    imu : ImuErrors
    step_s : ndarray, shape (M,)
    estimated : (tuple of str, tuple of str)
        As `bias_step_densities`.

    Returns
    -------
    (ndarray (P, M, 6), ndarray of bool (P,)) or None
        Each path's densities and whether its input changes (where not, its densities are
        0 and `bias_step_densities` gives None); None when the grade has no scale factor
        or misalignment.
    """
    sf_a, sf_g = imu.accel_scale_factor_ppm * _PPM, imu.gyro_scale_factor_ppm * _PPM
    m_a, m_g = imu.accel_misalignment_rad, imu.gyro_misalignment_rad
    if sf_a == sf_g == m_a == m_g == 0.0:
        return None
    n_paths, m = params.shape[0], params.shape[1] + 1
    rows = np.concatenate([params_prev[:, None, :], params], axis=1)
    speed = speed_mps if np.ndim(speed_mps) == 0 else np.repeat(speed_mps, m)
    f_d, w_d = kinematic_inputs(rows.reshape(n_paths * m, rows.shape[2]), speed)
    f_d, w_d = f_d.reshape(n_paths, m, 3), w_d.reshape(n_paths, m, 3)
    d_f, d_w = np.abs(np.diff(f_d ** 2, axis=1)), np.abs(np.diff(w_d ** 2, axis=1))
    changes = d_f.any(axis=(1, 2)) | d_w.any(axis=(1, 2))
    variance = np.concatenate([_axis_variances(d_f, sf_a, m_a),
                               _axis_variances(d_w, sf_g, m_g)], axis=2)
    if any(estimated):
        _leave_out(variance, (d_f, d_w), ((sf_a, m_a), (sf_g, m_g)), estimated)
    return variance / np.asarray(step_s, dtype=float)[None, :, None], changes


def weighted_path_densities(nodes: list[tuple[float, float]], found) -> Array | None:
    """The spread's total: each path's densities (`path_bias_step_densities`'s result,
    None: none) times its node's weight (`step_nodes`), summed in the nodes' order over
    the paths whose input changes, shape (M, 6); None when none does."""
    bias = None
    for (_, weight), one, changes in zip(nodes, *(found or ((), ()))):
        if changes:
            bias = weight * one if bias is None else bias + weight * one
    return bias
