"""Equations shared by the full and the track-constrained mechanizations.

ARCHITECTURE.md "Physics", in ``n`` = ENU::

    dv_n/dt   = C_b_n f_b − (2 ω_ie_n + ω_en_n) × v_n + g_n
    [ψ̇, θ̇, φ̇] = E(θ, φ) · (ω_ib_b − C_b_nᵀ (ω_ie_n + ω_en_n))

(``E`` from `strapdown.euler`, derived from ``C_b_n``: the attitude equation is the
Euler-angle form of ``dC_b_n/dt = C_b_n [ω_ib_b×] − [ω_in_n×] C_b_n``.)

Also the optional sensor-bias augmentation: accelerometer and gyro biases as states with
first-order Gauss–Markov dynamics ``ḃ = −b/τ`` (``τ = inf``: random constant); the
model subtracts them from the measured inputs. Optionally also chosen elements ``(i, j)``
of a triad's scale-factor and misalignment matrix ``S + M`` (`strapdown.imu_errors`) as
random constants ``k_ij`` (`scale_state_name`): the triad reads ``y = (I + S + M) x + b``,
so ``x_i ≈ y_i − b_i − Σ_j k_ij y_j`` over the chosen elements of row ``i``, to first order
in ``S + M``. The error an element causes follows the *measured* input ``y_j``, so it steps
exactly when the sensor's input does (where the curvature of the track steps), whatever
the filter's estimate of where the train is.

Written for CasADi symbols (builders); the functions also work on NumPy arrays through
`strapdown.backend`.

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
           "ATTITUDE_NAMES", "SensorBiasStates", "scale_state_name", "SCALE_BLOCK",
           "navigation_acceleration", "attitude_rates",
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
#: Body axes, in the order of the triads' components.
_AXES = ("x", "y", "z")
#: Short names of the triads whose ``S + M`` elements may be states: accelerometer, gyro.
_SENSORS = ("a", "g")
#: Name of the state block of the ``S + M`` elements (after the bias blocks).
SCALE_BLOCK = "imu_scale"


def scale_state_name(sensor: str, element: str) -> str:
    """Name of the state of element `element` of a triad's ``S + M``.

    Parameters
    ----------
    sensor : str
        ``"a"`` (accelerometer) or ``"g"`` (gyro).
    element : str
        Row (the sensor's axis) then column (the input axis it multiplies), e.g. ``"zy"``:
        the z accelerometer's misalignment towards y, ``M_zy`` (``"yy"``: the scale factor
        ``S_yy``).

    Returns
    -------
    str
        ``k_<sensor>_<row><column>`` (the state is dimensionless).
    """
    if sensor not in _SENSORS or len(element) != 2 or not set(element) <= set(_AXES):
        raise StrapdownError(f"scale state: sensor must be one of {_SENSORS} and element "
                             f"two of {_AXES} (row, column), got {sensor!r}, {element!r}")
    return f"k_{sensor}_{element}"


@dataclass(frozen=True)
class SensorBiasStates:
    """Sensor biases as extra states with Gauss–Markov dynamics ``ḃ = −b/τ``.

    Parameters
    ----------
    accel_tau_s : float
        Correlation time of the accelerometer bias states, s (``inf``: random constant).
    gyro_tau_s : float
        Correlation time of the gyro bias states, s (``inf``: random constant).
    accel_scale_elements, gyro_scale_elements : tuple of str
        Elements ``"<row><column>"`` of the triad's ``S + M`` that are states (random
        constants, `scale_state_name`), e.g. ``("zy",)``; default none. Kept in row-major
        order.
    """

    accel_tau_s: float = math.inf
    gyro_tau_s: float = math.inf
    accel_scale_elements: tuple[str, ...] = ()
    gyro_scale_elements: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("accel_tau_s", "gyro_tau_s"):
            value = getattr(self, name)
            if not value > 0:
                raise StrapdownError(f"{name} must be > 0 (inf for a constant), got {value!r}")
        for sensor, name in zip(_SENSORS, ("accel_scale_elements", "gyro_scale_elements")):
            elements = tuple(getattr(self, name))
            for element in elements:
                scale_state_name(sensor, element)           # validates
            if len(set(elements)) != len(elements):
                raise StrapdownError(f"{name} must be distinct, got {elements!r}")
            object.__setattr__(self, name, tuple(sorted(
                elements, key=lambda e: (_AXES.index(e[0]), _AXES.index(e[1])))))

    def scale_names(self) -> tuple[str, ...]:
        """Names of the ``S + M`` element states, accelerometer then gyro (empty without)."""
        return tuple(scale_state_name(sensor, element) for sensor, elements
                     in zip(_SENSORS, (self.accel_scale_elements, self.gyro_scale_elements))
                     for element in elements)

    def blocks(self) -> tuple:
        """The state blocks this adds to a model: `BIAS_BLOCKS`, then `SCALE_BLOCK` when
        there are ``S + M`` element states."""
        names = self.scale_names()
        return BIAS_BLOCKS + (((SCALE_BLOCK, names),) if names else ())


def _scale_correction(y: Any, elements: tuple[str, ...], k: Any) -> Any:
    """``Σ_j k_ij y_j`` per row ``i`` (3x1) over `elements` (``"<i><j>"``), with ``k``
    their states in that order."""
    rows = [0.0, 0.0, 0.0]
    for n, element in enumerate(elements):
        i, j = _AXES.index(element[0]), _AXES.index(element[1])
        rows[i] = rows[i] + k[n] * y[j]
    return ca.vertcat(*rows)


def corrected_inputs(u: Any, bias: Any | None,
                     biases: SensorBiasStates | None) -> tuple[Any, Any, Any | None]:
    """Split the input and remove modelled biases (and ``S + M`` elements).

    Parameters
    ----------
    u : casadi 6x1
        ``[f_b, ω_ib_b]`` as measured (`INPUT_LAYOUT`).
    bias : casadi (6 + n_k)x1 or None
        Bias states ``[b_a, b_g]`` (`BIAS_LAYOUT`; when `biases` is given), then the
        ``n_k`` states of `SensorBiasStates.scale_names`, in order.
    biases : SensorBiasStates or None

    Returns
    -------
    f_b, omega_ib_b : casadi 3x1
        Corrected specific force (m/s²) and angular rate (rad/s), body frame:
        ``y_i − b_i − Σ_j k_ij y_j`` (module docstring).
    bias_dot : casadi (6 + n_k)x1 or None
        Time derivative of the bias states (0 for the ``S + M`` elements: constants).
    """
    f_b, omega_ib_b = u[INPUT_LAYOUT.slice("f_b")], u[INPUT_LAYOUT.slice("omega_ib_b")]
    if biases is None:
        return f_b, omega_ib_b, None
    b_a, b_g = bias[BIAS_LAYOUT.slice("accel_bias")], bias[BIAS_LAYOUT.slice("gyro_bias")]
    rate_a = 0.0 if math.isinf(biases.accel_tau_s) else 1.0 / biases.accel_tau_s
    rate_g = 0.0 if math.isinf(biases.gyro_tau_s) else 1.0 / biases.gyro_tau_s
    f_out, omega_out = f_b - b_a, omega_ib_b - b_g
    n_a, n_g = len(biases.accel_scale_elements), len(biases.gyro_scale_elements)
    k = bias[BIAS_LAYOUT.size:BIAS_LAYOUT.size + n_a + n_g] if n_a + n_g else None
    if n_a:
        f_out = f_out - _scale_correction(f_b, biases.accel_scale_elements, k[:n_a])
    if n_g:
        omega_out = omega_out - _scale_correction(omega_ib_b, biases.gyro_scale_elements,
                                                  k[n_a:])
    rates = [-rate_a * b_a, -rate_g * b_g] + ([ca.SX.zeros(n_a + n_g)] if n_a + n_g else [])
    return f_out, omega_out, ca.vertcat(*rates)


@dataclass(frozen=True)
class ModelSymbols:
    """The symbols a model builder starts from.

    Attributes
    ----------
    layout : ekf.StateLayout
        Navigation states, then the bias blocks (`SensorBiasStates.blocks`) when modelled.
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
        When given, its blocks (`SensorBiasStates.blocks`: `BIAS_BLOCKS`, then the ``S + M``
        elements) are appended to the layout.

    Returns
    -------
    ModelSymbols
    """
    blocks = () if biases is None else biases.blocks()
    layout = navigation.extended(blocks) if blocks else navigation
    x = ca.SX.sym("x", layout.size)
    u = ca.SX.sym("u", INPUT_LAYOUT.size)
    bias = ca.vertcat(*(x[layout.slice(name)] for name, _ in blocks)) \
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
