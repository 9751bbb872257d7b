r"""Attitude: the body->ENU DCM from yaw, pitch, roll and the Euler-rate matrix derived from it.

This module owns the attitude convention (ARCHITECTURE.md, "Attitude"):

* frames: ``n`` = East-North-Up, ``b`` = body with x forward, y left, z up;
* yaw ``ψ`` = azimuth of the body x-axis, clockwise from north (= track azimuth ``A``);
  pitch ``θ`` = elevation of the body x-axis (= track elevation ``ϑ``), the middle angle;
  roll ``φ`` = right-handed rotation about body x (left side up, right side down);
* ``C_b_n = R_z(π/2 − ψ) · R_y(−θ) · R_x(φ)`` with the active elementary rotations
  ``R_z(α) = [[cα, −sα, 0], [sα, cα, 0], [0, 0, 1]]`` etc., i.e. ::

      C_b_n = [[ sψ cθ,  −sψ sθ sφ − cψ cφ,  −sψ sθ cφ + cψ sφ],
               [ cψ cθ,  −cψ sθ sφ + sψ cφ,  −cψ sθ cφ − sψ sφ],
               [ sθ,      cθ sφ,               cθ cφ           ]]

  Its first column is the track tangent ``u = [cθ sψ, cθ cψ, sθ]``; with zero roll its
  second and third columns are the horizontal left vector and the track normal.

Euler kinematics, derived from this DCM (not the 2017 paper's matrix, SEEDS.md erratum 1):
the body rate relative to ``n`` is the sum of the three elementary rates seen in ``b``,
``ω_nb_b = −ψ̇ C_n_b e_z − θ̇ R_x(φ)ᵀ e_y + φ̇ e_x``, i.e. ::

      ω_nb_b = [φ̇ − ψ̇ sθ,  −θ̇ cφ − ψ̇ cθ sφ,  θ̇ sφ − ψ̇ cθ cφ]

and its inverse ``[ψ̇, θ̇, φ̇] = E(θ, φ) ω_nb_b`` with ::

      E = [[0, −sφ/cθ,   −cφ/cθ ],
           [0, −cφ,       sφ    ],
           [1, −sφ tθ,   −cφ tθ ]]

``E`` is singular at ``cos θ = 0`` (body x vertical: gimbal lock). On rails ``|θ|`` is a
few degrees, so the navigation states never come near it; the functions here return
inf/nan there rather than raising. ``dC_b_n/dt = C_b_n [ω_nb_b ×]`` is tested numerically.

Every function takes NumPy arrays (broadcast over leading axes) or CasADi symbols
(see `strapdown.backend`).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from strapdown.backend import ops_for

__all__ = ["C_b_n", "euler_rate_matrix", "euler_rates", "omega_nb_b_from_rates",
           "euler_from_C_b_n", "skew", "relative_dcm"]


def C_b_n(yaw: Any, pitch: Any, roll: Any) -> Any:
    """Body->ENU direction cosine matrix.

    Parameters
    ----------
    yaw, pitch, roll : array_like or casadi scalar
        Euler angles of ``b`` relative to ``n``, rad (convention in the module docstring).

    Returns
    -------
    ndarray, shape (..., 3, 3), or casadi 3x3
        ``v_n = C_b_n @ v_b``.
    """
    ops = ops_for(yaw, pitch, roll)
    sy, cy = ops.sin(yaw), ops.cos(yaw)
    sp, cp = ops.sin(pitch), ops.cos(pitch)
    sr, cr = ops.sin(roll), ops.cos(roll)
    return ops.mat3([
        [sy * cp, -sy * sp * sr - cy * cr, -sy * sp * cr + cy * sr],
        [cy * cp, -cy * sp * sr + sy * cr, -cy * sp * cr - sy * sr],
        [sp, cp * sr, cp * cr],
    ])


def relative_dcm(yaw: Any, pitch: Any, roll: Any) -> Any:
    """DCM from a frame ``a`` to a frame ``c`` with the same axis convention (x forward, y
    left, z up), ``c`` turned from ``a`` by yaw (clockwise seen from above, like ψ), then
    pitch (x up), then roll: ``R_z(−ψ) R_y(−θ) R_x(φ)``, i.e. ``R_z(π/2)ᵀ C_b_n(ψ, θ, φ)``,
    so that ``C_b_n(ψ₁, 0, 0) relative_dcm(ψ₂, 0, 0) = C_b_n(ψ₁ + ψ₂, 0, 0)`` and
    ``relative_dcm(0, 0, 0) = I``. Used for an IMU's mounting on a car body.

    Returns
    -------
    ndarray, shape (..., 3, 3), or casadi 3x3
        ``v_a = relative_dcm(...) @ v_c``.
    """
    ops = ops_for(yaw, pitch, roll)
    sy, cy = ops.sin(yaw), ops.cos(yaw)
    sp, cp = ops.sin(pitch), ops.cos(pitch)
    sr, cr = ops.sin(roll), ops.cos(roll)
    return ops.mat3([
        [cy * cp, -cy * sp * sr + sy * cr, -cy * sp * cr - sy * sr],
        [-sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [sp, cp * sr, cp * cr],
    ])


def euler_rate_matrix(pitch: Any, roll: Any) -> Any:
    """``E(θ, φ)`` mapping ``ω_nb_b`` to ``[ψ̇, θ̇, φ̇]`` (singular at ``cos θ = 0``).

    Parameters
    ----------
    pitch, roll : array_like or casadi scalar
        rad.

    Returns
    -------
    ndarray, shape (..., 3, 3), or casadi 3x3
        1/s per rad/s (dimensionless).
    """
    ops = ops_for(pitch, roll)
    sr, cr = ops.sin(roll), ops.cos(roll)
    cp, tp = ops.cos(pitch), ops.tan(pitch)
    zero = 0.0 * pitch
    return ops.mat3([
        [zero, -sr / cp, -cr / cp],
        [zero, -cr, sr],
        [zero + 1.0, -sr * tp, -cr * tp],
    ])


def euler_rates(pitch: Any, roll: Any, omega_nb_b: Any) -> Any:
    """``[ψ̇, θ̇, φ̇]`` (rad/s) from the body rate relative to ``n``, ``ω_nb_b`` (rad/s, b)."""
    ops = ops_for(pitch, roll, omega_nb_b)
    return ops.matvec(euler_rate_matrix(pitch, roll), omega_nb_b)


def omega_nb_b_from_rates(pitch: Any, roll: Any, rates: Any) -> Any:
    """Inverse of `euler_rates`: ``ω_nb_b`` (rad/s, b) from ``[ψ̇, θ̇, φ̇]`` (rad/s).

    Non-singular everywhere (it is the forward kinematic map).
    """
    ops = ops_for(pitch, roll, rates)
    sp, cp = ops.sin(pitch), ops.cos(pitch)
    sr, cr = ops.sin(roll), ops.cos(roll)
    dyaw, dpitch, droll = (ops.comp(rates, i) for i in range(3))
    return ops.vec3(droll - dyaw * sp,
                    -dpitch * cr - dyaw * cp * sr,
                    dpitch * sr - dyaw * cp * cr)


def euler_from_C_b_n(C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Yaw, pitch, roll (rad) of a body->ENU DCM (NumPy only).

    Parameters
    ----------
    C : ndarray, shape (..., 3, 3)

    Returns
    -------
    yaw : ndarray, shape (...)
        In ``[0, 2π)``, rad.
    pitch : ndarray
        In ``[−π/2, π/2]``, rad.
    roll : ndarray
        In ``(−π, π]``, rad.
    """
    C = np.asarray(C, dtype=float)
    yaw = np.mod(np.arctan2(C[..., 0, 0], C[..., 1, 0]), 2.0 * np.pi)
    pitch = np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(C[..., 2, 1], C[..., 2, 2])
    return yaw, pitch, roll


def skew(w: Any) -> Any:
    """Cross-product matrix ``[w×]`` with ``[w×] a = w × a``.

    Parameters
    ----------
    w : array_like, shape (..., 3), or casadi 3x1

    Returns
    -------
    ndarray, shape (..., 3, 3), or casadi 3x3
    """
    ops = ops_for(w)
    x, y, z = (ops.comp(w, i) for i in range(3))
    zero = 0.0 * x
    return ops.mat3([[zero, -z, y], [z, zero, -x], [-y, x, zero]])
