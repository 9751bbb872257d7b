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

from ekf.layout import StateLayout
from strapdown.euler import C_b_n
from strapdown.frames import radii_of_curvature
from strapdown.kinematics import (ATTITUDE_NAMES, SensorBiasStates, attitude_rates,
                                  model_symbols, navigation_acceleration)
from trackmodel.earth import WGS84, Ellipsoid

__all__ = ["FULL_STATE_LAYOUT", "FULL_STATE_NAMES", "VELOCITY_NAMES", "POSITION_NAMES",
           "FullModel", "build_full_model"]

#: Velocity components, m/s, ENU (block ``"velocity"``).
VELOCITY_NAMES = ("v_E", "v_N", "v_U")
#: Geodetic position: latitude and longitude (rad), height (m) (block ``"position"``).
POSITION_NAMES = ("lat", "lon", "h")
#: The 9 navigation states of the full model, by block.
FULL_STATE_LAYOUT = StateLayout.from_blocks([("attitude", ATTITUDE_NAMES),
                                             ("velocity", VELOCITY_NAMES),
                                             ("position", POSITION_NAMES)])
#: Names of the 9 navigation states of the full model.
FULL_STATE_NAMES = FULL_STATE_LAYOUT.names


@dataclass(frozen=True)
class FullModel:
    """The full mechanization ``ẋ = f(x, u)`` and its Jacobians.

    Attributes
    ----------
    layout : ekf.StateLayout
        `FULL_STATE_LAYOUT` (9 states), extended by the bias blocks (15) with sensor biases.
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
    sym = model_symbols(FULL_STATE_LAYOUT, biases)
    x, u, f_b, omega_ib_b, bias_dot = sym.x, sym.u, sym.f_b, sym.omega_ib_b, sym.bias_dot
    layout = sym.layout
    yaw, pitch, roll = (x[layout.index(name)] for name in ATTITUDE_NAMES)
    v_E, v_N, v_U = (x[layout.index(name)] for name in VELOCITY_NAMES)
    v_n, lat, h = x[layout.slice("velocity")], x[layout.index("lat")], x[layout.index("h")]

    C = C_b_n(yaw, pitch, roll)
    a_n, omega_in_n = navigation_acceleration(C, f_b, v_n, lat, h, earth=earth)
    R_M, R_N = radii_of_curvature(lat, earth=earth)
    pos_dot = ca.vertcat(v_N / (R_M + h), v_E / ((R_N + h) * ca.cos(lat)), v_U)
    parts = [attitude_rates(yaw, pitch, roll, omega_ib_b, omega_in_n), a_n, pos_dot]
    if bias_dot is not None:
        parts.append(bias_dot)
    xdot = ca.vertcat(*parts)

    f = ca.Function("full_f", [x, u], [xdot], ["x", "u"], ["xdot"])
    F_x = ca.Function("full_F_x", [x, u], [ca.jacobian(xdot, x)], ["x", "u"], ["F_x"])
    G = ca.Function("full_G", [x, u], [ca.jacobian(xdot, u)], ["x", "u"], ["G"])
    return FullModel(layout=sym.layout, f=f, F_x=F_x, G=G, earth=earth, biases=biases)
