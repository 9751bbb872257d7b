"""Equations shared by the full and the track-constrained mechanizations.

ARCHITECTURE.md "Physics", in ``n`` = ENU::

    dv_n/dt   = C_b_n f_b − (2 ω_ie_n + ω_en_n) × v_n + g_n
    [ψ̇, θ̇, φ̇] = E(θ, φ) · (ω_ib_b − C_b_nᵀ (ω_ie_n + ω_en_n))

(``E`` from `strapdown.euler`, derived from ``C_b_n``: the attitude equation is the
Euler-angle form of ``dC_b_n/dt = C_b_n [ω_ib_b×] − [ω_in_n×] C_b_n``.)

Also the optional sensor-bias augmentation: accelerometer and gyro biases as states with
first-order Gauss–Markov dynamics ``ḃ = −b/τ`` (``τ = inf``: random constant); the
model subtracts them from the measured inputs. Written for CasADi symbols (builders);
the functions also work on NumPy arrays through `strapdown.backend`.

Vectors are addressed by name through the one layout object, `ekf.layout.StateLayout`
(`INPUT_LAYOUT`, `BIAS_LAYOUT`, and the models' state layouts), never by literal index.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca

from ekf.layout import StateLayout
from strapdown.backend import ops_for
from strapdown.errors import StrapdownError
from strapdown.euler import C_b_n, euler_rates
from strapdown.frames import omega_en_n, omega_ie_n
from strapdown.gravity import g_n
from trackmodel.earth import WGS84, Ellipsoid

__all__ = ["INPUT_LAYOUT", "INPUT_NAMES", "BIAS_BLOCKS", "BIAS_LAYOUT", "BIAS_STATE_NAMES",
           "ATTITUDE_NAMES", "SensorBiasStates", "navigation_acceleration", "attitude_rates",
           "corrected_inputs", "ModelSymbols", "model_symbols"]

#: The IMU input vector ``u`` of every model: specific force (m/s², b) then angular rate of
#: ``b`` w.r.t. inertial space (rad/s, b), instantaneous values at the sample time.
INPUT_LAYOUT = StateLayout.from_blocks([("f_b", ("f_x", "f_y", "f_z")),
                                        ("omega_ib_b", ("omega_x", "omega_y", "omega_z"))])
INPUT_NAMES = INPUT_LAYOUT.names
#: The optional bias states, as blocks appended to a model's state layout: accelerometer
#: (m/s², b) then gyro (rad/s, b).
BIAS_BLOCKS = (("accel_bias", ("b_ax", "b_ay", "b_az")), ("gyro_bias", ("b_gx", "b_gy", "b_gz")))
#: The bias vector ``[b_a, b_g]`` on its own.
BIAS_LAYOUT = StateLayout.from_blocks(BIAS_BLOCKS)
BIAS_STATE_NAMES = BIAS_LAYOUT.names
#: Names of the attitude states (Euler angles of ``b`` relative to ``n``, rad) that both
#: models start with, block ``"attitude"``.
ATTITUDE_NAMES = ("yaw", "pitch", "roll")


@dataclass(frozen=True)
class SensorBiasStates:
    """Sensor biases as extra states with Gauss–Markov dynamics ``ḃ = −b/τ``.

    Parameters
    ----------
    accel_tau_s : float
        Correlation time of the accelerometer bias states, s (``inf``: random constant).
    gyro_tau_s : float
        Correlation time of the gyro bias states, s (``inf``: random constant).
    """

    accel_tau_s: float = math.inf
    gyro_tau_s: float = math.inf

    def __post_init__(self) -> None:
        for name in ("accel_tau_s", "gyro_tau_s"):
            value = getattr(self, name)
            if not value > 0:
                raise StrapdownError(f"{name} must be > 0 (inf for a constant), got {value!r}")


def corrected_inputs(u: Any, bias: Any | None,
                     biases: SensorBiasStates | None) -> tuple[Any, Any, Any | None]:
    """Split the input and remove modelled biases.

    Parameters
    ----------
    u : casadi 6x1
        ``[f_b, ω_ib_b]`` as measured (`INPUT_LAYOUT`).
    bias : casadi 6x1 or None
        Bias states ``[b_a, b_g]`` (`BIAS_LAYOUT`; when `biases` is given).
    biases : SensorBiasStates or None

    Returns
    -------
    f_b, omega_ib_b : casadi 3x1
        Corrected specific force (m/s²) and angular rate (rad/s), body frame.
    bias_dot : casadi 6x1 or None
        Time derivative of the bias states.
    """
    f_b, omega_ib_b = u[INPUT_LAYOUT.slice("f_b")], u[INPUT_LAYOUT.slice("omega_ib_b")]
    if biases is None:
        return f_b, omega_ib_b, None
    b_a, b_g = bias[BIAS_LAYOUT.slice("accel_bias")], bias[BIAS_LAYOUT.slice("gyro_bias")]
    rate_a = 0.0 if math.isinf(biases.accel_tau_s) else 1.0 / biases.accel_tau_s
    rate_g = 0.0 if math.isinf(biases.gyro_tau_s) else 1.0 / biases.gyro_tau_s
    return f_b - b_a, omega_ib_b - b_g, ca.vertcat(-rate_a * b_a, -rate_g * b_g)


@dataclass(frozen=True)
class ModelSymbols:
    """The symbols a model builder starts from.

    Attributes
    ----------
    layout : ekf.StateLayout
        Navigation states, then the bias blocks `BIAS_BLOCKS` when modelled.
    x, u : casadi.SX
        State (n_x) and IMU input (6) symbols.
    f_b, omega_ib_b : casadi.SX
        Bias-corrected specific force (m/s²) and angular rate (rad/s), body frame.
    bias_dot : casadi.SX or None
        Rates of the bias states.
    """

    layout: StateLayout
    x: Any
    u: Any
    f_b: Any
    omega_ib_b: Any
    bias_dot: Any


def model_symbols(navigation: StateLayout, biases: SensorBiasStates | None) -> ModelSymbols:
    """State/input symbols for the navigation states of `navigation` (+ biases if given).

    Parameters
    ----------
    navigation : ekf.StateLayout
        The model's navigation states.
    biases : SensorBiasStates or None
        When given, the bias blocks `BIAS_BLOCKS` are appended to the layout.

    Returns
    -------
    ModelSymbols
    """
    layout = navigation.extended(BIAS_BLOCKS) if biases is not None else navigation
    x = ca.SX.sym("x", layout.size)
    u = ca.SX.sym("u", INPUT_LAYOUT.size)
    bias = ca.vertcat(*(x[layout.slice(name)] for name, _ in BIAS_BLOCKS)) \
        if biases is not None else None
    f_b, omega_ib_b, bias_dot = corrected_inputs(u, bias, biases)
    return ModelSymbols(layout, x, u, f_b, omega_ib_b, bias_dot)


def navigation_acceleration(C: Any, f_b: Any, v_n: Any, lat: Any, h: Any, *,
                            earth: Ellipsoid = WGS84) -> tuple[Any, Any]:
    """Acceleration ``dv_n/dt`` of the Earth-relative velocity, and ``ω_in_n``.

    Parameters
    ----------
    C : 3x3
        ``C_b_n``.
    f_b : 3-vector
        Specific force, m/s², body frame.
    v_n : 3-vector
        Velocity relative to the Earth, m/s, ENU.
    lat, h : scalar
        Geodetic latitude (rad) and height (m).
    earth : Ellipsoid

    Returns
    -------
    a_n : 3-vector
        ``C_b_n f_b − (2 ω_ie_n + ω_en_n) × v_n + g_n``, m/s², ENU.
    omega_in_n : 3-vector
        ``ω_ie_n + ω_en_n``, rad/s, ENU.
    """
    ops = ops_for(C, f_b, v_n, lat, h)
    w_ie = omega_ie_n(lat, earth=earth)
    w_en = omega_en_n(v_n, lat, h, earth=earth)
    a_n = ops.matvec(C, f_b) - ops.cross(2.0 * w_ie + w_en, v_n) + g_n(lat, h, earth=earth)
    return a_n, w_ie + w_en


def attitude_rates(yaw: Any, pitch: Any, roll: Any, omega_ib_b: Any, omega_in_n: Any) -> Any:
    """``[ψ̇, θ̇, φ̇]`` (rad/s) from the inertial body rate and the navigation-frame rate.

    ``ω_nb_b = ω_ib_b − C_b_nᵀ ω_in_n`` (rad/s, b), then the Euler-rate matrix of
    `strapdown.euler`.
    """
    ops = ops_for(yaw, pitch, roll, omega_ib_b, omega_in_n)
    omega_nb_b = omega_ib_b - ops.mat_t_vec(C_b_n(yaw, pitch, roll), omega_in_n)
    return euler_rates(pitch, roll, omega_nb_b)
