r"""The track-constrained (reduced) mechanization as CasADi functions.

State ``x`` (`REDUCED_STATE_NAMES`)::

    [yaw, pitch, roll, s, v]      (+ optional 6 sensor-bias states, `SensorBiasStates`)

angles in rad, along-track distance ``s`` in m, signed speed ``v = ds/dt`` in m/s. Input
``u = [f_b (m/s², b), ω_ib_b (rad/s, b)]``, the instantaneous IMU sample. The vehicle
velocity is ``v_n = v u(s)``. Dynamics and the accelerometer pseudo-observation
(ARCHITECTURE.md "Physics"; the paper's eq. 12 in a basis that is never singular)::

    [ψ̇, θ̇, φ̇] = E(θ, φ) (ω_ib_b − C_b_nᵀ (ω_ie_n + ω_en_n(v u, φ, h)))
    ṡ = v
    v̇ = uᵀ a_n,          a_n = C_b_n f_b − (2 ω_ie_n + ω_en_n) × v u + g_n
    h_c = P⊥ (a_n − v² du/ds)  = 0  for a vehicle on the track

``P⊥`` has two rows, the unit vectors across the tangent ``û = u/|u|`` with
``c = sqrt(û_E² + û_N²) = cos ϑ``::

    lateral  l = [−û_N/c,  û_E/c,  0]              (horizontal, left of the track)
    normal   n = û × l = [−û_U û_E/c, −û_U û_N/c, c]   (track normal, upward)

valid for every azimuth (0°, 90°, 180°, 270° alike) and every grade short of a vertical
track (``c = 0``). With zero roll they are the body y and z axes. The accelerometer
white noise ``w_a`` (body) enters as ``u ← u + [w_a, w_g]``: process noise
``G = ∂f/∂u`` and pseudo-observation noise ``D = ∂h_c/∂u = P⊥ C_b_n [I 0]`` are
correlated through ``w_a``.

**Track parameters** ``p`` (`TRACK_PARAMETER_NAMES`, 16 values) linearize the track around
a reference distance ``s_ref`` (ideally the current estimate, refreshed every step)::

    p = [s_ref, lat_ref, lon_ref, h_ref, dlat_ds, dlon_ds, dh_ds,
         u_n_ref (3), du_ds_n_ref (3), d2u_ds2_n_ref (3)]

and inside the model, with ``δ = s − s_ref``: ``lat = lat_ref + dlat_ds δ``,
``h = h_ref + dh_ds δ + ½ du_U/ds δ²``, ``u = u_ref + du_ds_ref δ + ½ d2u_ds2_ref δ²``,
``du/ds = du_ds_ref + d2u_ds2_ref δ``, so CasADi's Jacobians with respect to ``s`` are those
of the track, and ``s_ref`` may lie a fraction of a metre from ``s`` (the first neglected
term of ``u`` is ``|d³u/ds³| δ³/6``, below 1e-9 at δ = 0.25 m on railway geometry). `track_parameters`
builds ``p`` from a `trackmodel` ``TrackPoint``.

`build_reduced_model(earth, biases=None)` -> `ReducedModel` (cached):
``f(x, u, p) -> xdot``, ``F_x``, ``G``, ``h_c(x, u, p) -> (2,)``, ``H_x``, ``D``.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ekf.layout import StateLayout
from strapdown.backend import ops_for
from strapdown.euler import C_b_n
from strapdown.frames import radii_of_curvature
from strapdown.kinematics import (ATTITUDE_NAMES, SensorBiasStates, attitude_rates,
                                  model_symbols, navigation_acceleration)
from trackmodel.earth import WGS84, Ellipsoid

__all__ = ["REDUCED_STATE_LAYOUT", "REDUCED_STATE_NAMES", "TRACK_PARAMETER_LAYOUT",
           "TRACK_PARAMETER_NAMES", "PSEUDO_OBSERVATION_NAMES", "ReducedModel",
           "build_reduced_model", "track_parameters", "cross_track_basis"]

#: The 5 navigation states of the reduced model, by block.
REDUCED_STATE_LAYOUT = StateLayout.from_blocks([("attitude", ATTITUDE_NAMES), ("s", 1),
                                                ("v", 1)])
#: Names of the 5 navigation states of the reduced model.
REDUCED_STATE_NAMES = REDUCED_STATE_LAYOUT.names
#: The per-step track parameter vector ``p``: scalars, then the tangent ``u_n`` and its
#: first and second derivatives along ``s`` as ENU blocks (module docstring).
TRACK_PARAMETER_LAYOUT = StateLayout.from_blocks([
    ("s_ref", 1), ("lat_ref", 1), ("lon_ref", 1), ("h_ref", 1),
    ("dlat_ds", 1), ("dlon_ds", 1), ("dh_ds", 1),
    ("u_n", ("u_E", "u_N", "u_U")), ("du_ds_n", ("du_E_ds", "du_N_ds", "du_U_ds")),
    ("d2u_ds2_n", ("d2u_E_ds2", "d2u_N_ds2", "d2u_U_ds2"))])
#: Names of the per-step track parameter vector ``p``.
TRACK_PARAMETER_NAMES = TRACK_PARAMETER_LAYOUT.names
#: Components of the accelerometer pseudo-observation ``h_c`` (m/s²).
PSEUDO_OBSERVATION_NAMES = ("lateral", "normal")


@dataclass(frozen=True)
class ReducedModel:
    """The track-constrained mechanization and its pseudo-observation.

    Attributes
    ----------
    layout : ekf.StateLayout
        `REDUCED_STATE_LAYOUT` (5 states), extended by the bias blocks (11) with sensor
        biases.
    f : casadi.Function
        ``f(x, u, p) -> xdot``: x (n_x,), u (6,), p (16,); xdot (n_x,), state units / s.
    F_x : casadi.Function
        ``F_x(x, u, p) -> (n_x, n_x)`` = ∂f/∂x.
    G : casadi.Function
        ``G(x, u, p) -> (n_x, 6)`` = ∂f/∂u (IMU noise -> state rates).
    h_c : casadi.Function
        ``h_c(x, u, p) -> (2,)``: lateral and normal residual, m/s² (0 on the track).
    H_x : casadi.Function
        ``H_x(x, u, p) -> (2, n_x)`` = ∂h_c/∂x.
    D : casadi.Function
        ``D(x, u, p) -> (2, 6)`` = ∂h_c/∂u (IMU noise -> pseudo-observation).
    earth : Ellipsoid
    biases : SensorBiasStates or None
    """

    layout: StateLayout
    f: ca.Function
    F_x: ca.Function
    G: ca.Function
    h_c: ca.Function
    H_x: ca.Function
    D: ca.Function
    earth: Ellipsoid
    biases: SensorBiasStates | None


def cross_track_basis(u_n: Any) -> tuple[Any, Any]:
    """Lateral and normal unit vectors across a tangent (CasADi 3x1 or NumPy (..., 3)).

    Parameters
    ----------
    u_n : casadi 3x1 or ndarray, shape (..., 3)
        Track tangent in ENU (need not be exactly unit length).

    Returns
    -------
    lateral, normal : same type and shape as `u_n`
        See the module docstring.
    """
    ops = ops_for(u_n)
    norm = ops.sqrt(ops.dot(u_n, u_n))
    east, north, up = (ops.comp(u_n, i) / norm for i in range(3))
    c = ops.sqrt(east * east + north * north)
    lateral = ops.vec3(-north / c, east / c, 0.0 * c)
    normal = ops.vec3(-up * east / c, -up * north / c, c)
    return lateral, normal


@functools.lru_cache(maxsize=None)
def build_reduced_model(earth: Ellipsoid = WGS84,
                        biases: SensorBiasStates | None = None) -> ReducedModel:
    """Build the track-constrained mechanization (see the module docstring).

    Parameters
    ----------
    earth : Ellipsoid
        Radii, rotation rate and gravity model; must be the track's Earth model.
    biases : SensorBiasStates, optional
        Add accelerometer and gyro bias states (Gauss–Markov).

    Returns
    -------
    ReducedModel
    """
    sym = model_symbols(REDUCED_STATE_LAYOUT, biases)
    x, u, f_b, omega_ib_b, bias_dot = sym.x, sym.u, sym.f_b, sym.omega_ib_b, sym.bias_dot
    yaw, pitch, roll, s, v = (x[sym.layout.index(name)] for name in REDUCED_STATE_NAMES)
    P = TRACK_PARAMETER_LAYOUT
    p = ca.SX.sym("p", P.size)

    def par(name: str) -> Any:
        return p[P.slice(name)]

    delta = s - par("s_ref")
    lat = par("lat_ref") + par("dlat_ds") * delta
    h = par("h_ref") + delta * (par("dh_ds") + 0.5 * par("du_U_ds") * delta)
    u_n = par("u_n") + delta * (par("du_ds_n") + 0.5 * par("d2u_ds2_n") * delta)
    du_ds_n = par("du_ds_n") + par("d2u_ds2_n") * delta

    C = C_b_n(yaw, pitch, roll)
    a_n, omega_in_n = navigation_acceleration(C, f_b, v * u_n, lat, h, earth=earth)
    parts = [attitude_rates(yaw, pitch, roll, omega_ib_b, omega_in_n), v, ca.dot(u_n, a_n)]
    if bias_dot is not None:
        parts.append(bias_dot)
    xdot = ca.vertcat(*parts)
    lateral, normal = cross_track_basis(u_n)
    residual = a_n - v * v * du_ds_n
    h_c = ca.vertcat(ca.dot(lateral, residual), ca.dot(normal, residual))

    args, names_in = [x, u, p], ["x", "u", "p"]

    def fn(name: str, expr: Any, out: str) -> ca.Function:
        return ca.Function(f"reduced_{name}", args, [expr], names_in, [out])

    return ReducedModel(
        layout=sym.layout,
        f=fn("f", xdot, "xdot"), F_x=fn("F_x", ca.jacobian(xdot, x), "F_x"),
        G=fn("G", ca.jacobian(xdot, u), "G"),
        h_c=fn("h_c", h_c, "h_c"), H_x=fn("H_x", ca.jacobian(h_c, x), "H_x"),
        D=fn("D", ca.jacobian(h_c, u), "D"),
        earth=earth, biases=biases)


def track_parameters(point: Any, *, earth: Ellipsoid = WGS84) -> np.ndarray:
    """The track parameter rows ``p`` at the points of a ``TrackPoint``.

    Parameters
    ----------
    point : trackmodel TrackPoint
        Arrays over N reference distances: ``s`` (m), ``lat``, ``lon`` (rad), ``h`` (m),
        ``u_n``, ``du_ds_n`` (1/m), ``d2u_ds2_n`` (1/m²), each (N, 3) in ENU.
    earth : Ellipsoid
        The track's Earth model (radii for ``dlat_ds``, ``dlon_ds``).

    Returns
    -------
    ndarray, shape (N, 16)
        Rows in the order of `TRACK_PARAMETER_NAMES`; ``dlat_ds`` = u_N/(R_M + h),
        ``dlon_ds`` = u_E/((R_N + h) cos lat) (rad/m), ``dh_ds`` = u_U.
    """
    P = TRACK_PARAMETER_LAYOUT
    s = np.atleast_1d(np.asarray(point.s, dtype=float))
    lat = np.atleast_1d(np.asarray(point.lat, dtype=float))
    lon = np.atleast_1d(np.asarray(point.lon, dtype=float))
    h = np.atleast_1d(np.asarray(point.h, dtype=float))
    u_n = np.atleast_2d(np.asarray(point.u_n, dtype=float))
    u_E, u_N, u_U = u_n.T
    R_M, R_N = radii_of_curvature(lat, earth=earth)
    out = np.empty((s.size, P.size))
    scalars = {"s_ref": s, "lat_ref": lat, "lon_ref": lon, "h_ref": h,
               "dlat_ds": u_N / (R_M + h), "dlon_ds": u_E / ((R_N + h) * np.cos(lat)),
               "dh_ds": u_U}
    for name, value in scalars.items():
        out[:, P.index(name)] = value
    for name, value in (("u_n", u_n), ("du_ds_n", point.du_ds_n),
                        ("d2u_ds2_n", point.d2u_ds2_n)):
        out[:, P.slice(name)] = np.atleast_2d(value)
    return out
