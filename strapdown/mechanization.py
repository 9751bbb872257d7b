"""The full (unconstrained) 9-state strapdown mechanization as CasADi functions.

State ``x`` (`FULL_STATE_NAMES`, SI units, rad)::

    [yaw, pitch, roll, v_E, v_N, v_U, lat, lon, h]   (+ optional 6 sensor-bias states)

Input ``u = [f_b (m/s², b), ω_ib_b (rad/s, b)]`` (`strapdown.kinematics.INPUT_NAMES`).
Dynamics (ARCHITECTURE.md "Physics"; geodetic position, ENU velocity)::

    [ψ̇, θ̇, φ̇] = E(θ, φ) (ω_ib_b − C_b_nᵀ ω_in_n)
    dv_n/dt   = C_b_n f_b − (2 ω_ie_n + ω_en_n) × v_n + g_n
    φ̇ = v_N/(R_M + h),  λ̇ = v_E/((R_N + h) cos φ),  ḣ = v_U

This is the free-inertial baseline: its vertical channel is unstable (the gravity
gradient feeds height errors back positively), which the closure tests report.

`build_full_model(earth, biases=None)` returns a `FullModel` of ``casadi.Function`` s,
built once per configuration (``functools.lru_cache``).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca

from strapdown.frames import radii_of_curvature
from strapdown.euler import C_b_n
from strapdown.kinematics import (SensorBiasStates, StateLayout, attitude_rates,
                                  model_symbols, navigation_acceleration)
from trackmodel.earth import WGS84, Ellipsoid

__all__ = ["FULL_STATE_NAMES", "FullModel", "build_full_model"]

#: Names of the 9 navigation states of the full model.
FULL_STATE_NAMES = ("yaw", "pitch", "roll", "v_E", "v_N", "v_U", "lat", "lon", "h")


@dataclass(frozen=True)
class FullModel:
    """The full mechanization ``ẋ = f(x, u)`` and its Jacobians.

    Attributes
    ----------
    layout : StateLayout
        State names (9, or 15 with sensor biases).
    f : casadi.Function
        ``f(x, u) -> xdot``; x (n_x,), u (6,), xdot (n_x,) in state units per second.
    F_x : casadi.Function
        ``F_x(x, u) -> (n_x, n_x)`` = ∂f/∂x.
    G : casadi.Function
        ``G(x, u) -> (n_x, 6)`` = ∂f/∂u, the map of IMU noise into the state rates.
    earth : Ellipsoid
    biases : SensorBiasStates or None
    """

    layout: StateLayout
    f: ca.Function
    F_x: ca.Function
    G: ca.Function
    earth: Ellipsoid
    biases: SensorBiasStates | None


@functools.lru_cache(maxsize=None)
def build_full_model(earth: Ellipsoid = WGS84,
                     biases: SensorBiasStates | None = None) -> FullModel:
    """Build the full 9-state (or 15-state with `biases`) mechanization.

    Parameters
    ----------
    earth : Ellipsoid
        Radii, rotation rate and gravity model (`strapdown.gravity`).
    biases : SensorBiasStates, optional
        Add accelerometer and gyro bias states (Gauss–Markov).

    Returns
    -------
    FullModel
    """
    sym = model_symbols(FULL_STATE_NAMES, biases)
    x, u, f_b, omega_ib_b, bias_dot = sym.x, sym.u, sym.f_b, sym.omega_ib_b, sym.bias_dot
    yaw, pitch, roll = x[0], x[1], x[2]
    v_n, lat, h = x[3:6], x[6], x[8]

    C = C_b_n(yaw, pitch, roll)
    a_n, omega_in_n = navigation_acceleration(C, f_b, v_n, lat, h, earth=earth)
    R_M, R_N = radii_of_curvature(lat, earth=earth)
    pos_dot = ca.vertcat(v_n[1] / (R_M + h), v_n[0] / ((R_N + h) * ca.cos(lat)), v_n[2])
    parts = [attitude_rates(yaw, pitch, roll, omega_ib_b, omega_in_n), a_n, pos_dot]
    if bias_dot is not None:
        parts.append(bias_dot)
    xdot = ca.vertcat(*parts)

    f = ca.Function("full_f", [x, u], [xdot], ["x", "u"], ["xdot"])
    F_x = ca.Function("full_F_x", [x, u], [ca.jacobian(xdot, x)], ["x", "u"], ["F_x"])
    G = ca.Function("full_G", [x, u], [ca.jacobian(xdot, u)], ["x", "u"], ["G"])
    return FullModel(layout=sym.layout, f=f, F_x=F_x, G=G, earth=earth, biases=biases)
