r"""An inertial mechanization augmented with the receiver clock: the inertial filters' model.

Both inertial filters (track-constrained, `railnav.filters.constrained_model`; unconstrained,
`railnav.filters.unconstrained_model`) run a strapdown mechanization (`strapdown`) with the
GNSS receiver clock appended. This module owns what they share, so that they are tuned
alike for the same configuration:

State (`ekf.StateLayout`, names used everywhere; never indices)::

    [<navigation states>, (b_ax, b_ay, b_az, b_gx, b_gy, b_gz, (k_<sensor>_<row><col> ...)),
     clock_bias, clock_drift, (isb_<system> ...)]

IMU biases m/s² and rad/s, optionally elements of the IMU's scale-factor and misalignment
matrices (dimensionless random constants, `strapdown.kinematics.scale_state_name`),
receiver clock bias m (``c δt_r``) and drift m/s, inter-system biases m (one per GNSS
system after the first, e.g. ``isb_E`` for Galileo time against GPS time).

Noise ``w`` (spectral densities ``q_c``, `InsClockModel.process_noise_density`)::

    [w_f (3, (m/s²)²·s), w_ω (3, (rad/s)²·s), (w_ba (3), w_bg (3), (w_k ...)), w_b (m²/s),
     w_d (m²/s³), (w_isb (m²/s) ...)]

The IMU white noise is an error of the measured input, so it enters the dynamics as
``G = −∂f/∂u`` and an optional continuous pseudo-observation as ``D = −∂h_c/∂u`` (the
SAME ``w_f``: the 2017 paper's eq. 14 correlated noise). IMU biases are random walks
(``ḃ = w``) whose density ``2σ²/τ`` matches the Gauss–Markov bias instability of the
grade over times short against ``τ``, plus a constant part carried by the initial
covariance. The ``S + M`` elements are constants (a random walk of negligible density,
so that every state has its noise column); their prior is the grade's scale-factor
(diagonal elements) or misalignment (off-diagonal) σ. The clock is the two-state
oscillator model of `gnss_obs.oscillator` (``ḃ = d + w_b``, ``ḋ = w_d``); inter-system
biases are random walks of density `ISB_RANDOM_WALK_M2PS`.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import CdModel
from gnss_obs.oscillator import Oscillator
from railnav.filters.odometer_epochs import SCALE_STATE
from strapdown.imu_errors import ImuErrors
from strapdown.kinematics import BIAS_STATE_NAMES, INPUT_NAMES, SCALE_BLOCK
from trackmodel.earth import Ellipsoid

__all__ = ["InsClockModel", "assemble_ins_clock_model", "CLOCK_STATE_NAMES",
           "ISB_RANDOM_WALK_M2PS", "isb_state_name", "clock_offset_columns",
           "bias_random_walk_density",
           "IMU_NOISE_NAMES", "model_name", "initial_variances", "scale_variances",
           "scale_element_sigma"]

Array = npt.NDArray[np.float64]
#: A function of the INS part of the state, the input and the per-step parameters.
InsExpression = Callable[[Any, Any, Any], Any]

#: Receiver clock states: bias (m) and drift (m/s).
CLOCK_STATE_NAMES = ("clock_bias", "clock_drift")
#: Spectral density of the inter-system bias random walk, m²/s (a slowly wandering
#: GPS-Galileo time offset of the receiver: ~0.3 m per hour).
ISB_RANDOM_WALK_M2PS = 1e-5
#: Names of the IMU white-noise components (accelerometer, then gyro; body axes).
IMU_NOISE_NAMES = ("w_fx", "w_fy", "w_fz", "w_wx", "w_wy", "w_wz")
#: The white noise the filter assumes for an ideal IMU (zero noise; accelerometer
#: m/s²/√Hz, gyro rad/√s): the 2017 paper's figures. The accelerometer observation's noise
#: must be positive, so a ``perfect`` IMU is filtered as if it had the paper's noise.
IDEAL_ACCEL_NOISE_DENSITY_MPS2_RTHZ = 1e-5
IDEAL_GYRO_NOISE_DENSITY_RADPS_RTHZ = 1e-6
#: Bias random walks are kept strictly positive so that the covariance stays definite.
_MIN_BIAS_DENSITY = 1e-30
#: Bias variances are kept positive so that P0 is definite even for a perfect IMU.
_MIN_BIAS_VARIANCE = 1e-16


def isb_state_name(system: str) -> str:
    """State name of the inter-system bias of a GNSS system letter (``"E"`` -> ``isb_E``)."""
    return f"isb_{system}"


def clock_offset_columns(layout: StateLayout) -> tuple[int, ...]:
    """Indices of the states a pseudorange sees as a receiver clock offset: ``clock_bias``
    and every inter-system bias (`isb_state_name`)."""
    prefix = isb_state_name("")
    return tuple(i for i, name in enumerate(layout.names)
                 if name == CLOCK_STATE_NAMES[0] or name.startswith(prefix))


def bias_random_walk_density(sigma: float, tau_s: float) -> float:
    """``2σ²/τ``: the random walk that follows a Gauss–Markov process for ``t ≪ τ``.

    Parameters
    ----------
    sigma : float
        Stationary σ of the Gauss–Markov bias (m/s² or rad/s).
    tau_s : float
        Its correlation time, s.

    Returns
    -------
    float
        Spectral density, (m/s²)²/s or (rad/s)²/s, floored at a tiny positive value.
    """
    return max(2.0 * sigma * sigma / tau_s, _MIN_BIAS_DENSITY)


@dataclass(frozen=True, eq=False)
class InsClockModel:
    """An inertial filter's process model (see the module docstring).

    Attributes
    ----------
    process : ekf.CdModel
        ``f(x, u, p)``, ``G`` (and ``h_c``, ``D`` when the mechanization has a continuous
        pseudo-observation) with ``u = [f_b, ω_ib_b]`` (6).
    layout : ekf.StateLayout
    earth : Ellipsoid
    estimate_biases : bool
    isb_systems : tuple of str
        Systems with an inter-system bias state.
    noise_names : tuple of str
        Names of the components of ``w`` (and of `process_noise_density`).
    extra_names : tuple of str
        The extra random-walk states (`assemble_ins_clock_model`'s `extra_blocks`).
    scale_names : tuple of str
        The IMU's ``S + M`` element states (`assemble_ins_clock_model`'s `scale_names`).
    """

    process: CdModel
    layout: StateLayout
    earth: Ellipsoid
    estimate_biases: bool
    isb_systems: tuple[str, ...]
    noise_names: tuple[str, ...]
    extra_names: tuple[str, ...] = ()
    scale_names: tuple[str, ...] = ()

    def process_noise_density(self, imu: ImuErrors, oscillator: Oscillator,
                              extra_q: tuple[float, ...] = ()) -> Array:
        """Diagonal spectral density ``q_c`` of ``w`` (units in the module docstring).

        Parameters
        ----------
        imu : ImuErrors
            The IMU grade the filter assumes (a zero white noise is replaced by the
            ``IDEAL_*_NOISE_DENSITY`` figures).
        oscillator : Oscillator
            The receiver clock the filter assumes.
        extra_q : tuple of float
            Densities of the extra random-walk states (`extra_names`), in order.

        Returns
        -------
        ndarray, shape (n_w,)
        """
        if len(extra_q) != len(self.extra_names):
            raise ValueError(f"{len(self.extra_names)} extra states, {len(extra_q)} densities")
        accel = imu.accel_noise_density_mps2_rthz or IDEAL_ACCEL_NOISE_DENSITY_MPS2_RTHZ
        gyro = imu.gyro_noise_density_radps_rthz or IDEAL_GYRO_NOISE_DENSITY_RADPS_RTHZ
        q = [accel ** 2] * 3 + [gyro ** 2] * 3
        if self.estimate_biases:
            q += [bias_random_walk_density(imu.accel_bias_instability_mps2,
                                           imu.accel_bias_tau_s)] * 3
            q += [bias_random_walk_density(imu.gyro_bias_instability_radps,
                                           imu.gyro_bias_tau_s)] * 3
            q += [_MIN_BIAS_DENSITY] * len(self.scale_names)
        q += [oscillator.q_bias_m2ps, oscillator.q_drift_m2ps3]
        q += [ISB_RANDOM_WALK_M2PS] * len(self.isb_systems)
        q += [max(float(v), _MIN_BIAS_DENSITY) for v in extra_q]
        return np.array(q, dtype=float)


def assemble_ins_clock_model(nav_blocks: Sequence, ins_f: InsExpression, ins_G: InsExpression,
                             *, earth: Ellipsoid, estimate_biases: bool,
                             isb_systems: tuple[str, ...], n_p: int, name: str,
                             ins_h_c: InsExpression | None = None,
                             ins_D: InsExpression | None = None,
                             extra_blocks: tuple = (), scale_names: tuple[str, ...] = ()
                             ) -> InsClockModel:
    """Append bias, clock and inter-system-bias states to a mechanization.

    Parameters
    ----------
    nav_blocks : sequence of (str, int or tuple of str)
        The navigation states' `ekf.StateLayout` blocks, in the mechanization's order.
    ins_f, ins_G : callable(x_ins, u, p) -> casadi.SX
        The mechanization's ``ẋ_ins`` (n_ins) and ``∂ẋ_ins/∂u`` (n_ins x 6), where
        ``x_ins`` is the navigation states followed by the six bias states when
        `estimate_biases` (random walks: the mechanization's own bias dynamics are 0),
        then the states of `scale_names`.
    earth : Ellipsoid
    estimate_biases : bool
    isb_systems : tuple of str
        GNSS systems that get an inter-system bias state.
    n_p : int
        Size of the per-step parameter vector ``p``.
    name : str
        Identifier of the generated code.
    ins_h_c, ins_D : callable(x_ins, u, p) -> casadi.SX, optional
        A continuous pseudo-observation (n_c) and its ``∂h_c/∂u`` (n_c x 6).
    extra_blocks : tuple of (str, tuple of str)
        Further random-walk states, appended last (the odometer's scale factor:
        `railnav.filters.sensor_rows.sensor_states`).
    scale_names : tuple of str
        Elements of the IMU's ``S + M`` as states, after the biases (with
        `estimate_biases`; `strapdown.kinematics.SensorBiasStates.scale_names`).

    Returns
    -------
    InsClockModel
    """
    blocks = list(nav_blocks)
    scale_names = tuple(scale_names) if estimate_biases else ()
    if estimate_biases:
        blocks.append(("imu_bias", BIAS_STATE_NAMES))
    if scale_names:
        blocks.append((SCALE_BLOCK, scale_names))
    blocks.append(("clock", CLOCK_STATE_NAMES))
    if isb_systems:
        blocks.append(("isb", tuple(isb_state_name(s) for s in isb_systems)))
    blocks += list(extra_blocks)
    extra_names = tuple(n for _, names in extra_blocks for n in names)
    layout = StateLayout.from_blocks(blocks)
    walk_names = (BIAS_STATE_NAMES + scale_names if estimate_biases else ()) + \
        CLOCK_STATE_NAMES + \
        tuple(isb_state_name(s) for s in isb_systems) + extra_names
    walk_states = [layout.index(n) for n in walk_names]
    n_ins = layout.index(CLOCK_STATE_NAMES[0])

    x = ca.SX.sym("x", layout.size)
    u = ca.SX.sym("u", len(INPUT_NAMES))
    p = ca.SX.sym("p", n_p)
    x_ins = x[:n_ins]
    n_after = layout.size - n_ins
    xdot = ca.vertcat(ins_f(x_ins, u, p), x[layout.index("clock_drift")],
                      ca.SX.zeros(n_after - 1))
    G_imu = ca.vertcat(-ins_G(x_ins, u, p), ca.SX.zeros(n_after, len(INPUT_NAMES)))
    G_walk = ca.SX.zeros(layout.size, len(walk_states))
    for col, row in enumerate(walk_states):
        G_walk[row, col] = 1.0
    h_c = D = None
    if ins_h_c is not None:
        h_c = ins_h_c(x_ins, u, p)
        D = ca.horzcat(-ins_D(x_ins, u, p), ca.SX.zeros(h_c.shape[0], len(walk_states)))
    process = CdModel.from_expressions(layout, x, u, p, xdot, h_c=h_c,
                                       G=ca.horzcat(G_imu, G_walk), D=D, name=name)
    noise_names = IMU_NOISE_NAMES + tuple(f"w_{n}" for n in walk_names)
    return InsClockModel(process=process, layout=layout, earth=earth,
                         estimate_biases=estimate_biases, isb_systems=tuple(isb_systems),
                         noise_names=noise_names, extra_names=extra_names,
                         scale_names=scale_names)


def initial_variances(config, layout: StateLayout) -> dict[str, float]:
    """Initial variances of the states every inertial filter has, by state name.

    Parameters
    ----------
    config : railnav.NavigatorConfig
        Its initial attitude, clock and inter-system-bias σ, and the IMU grade it assumes
        (each bias: its constant part and its instability, in quadrature; the ``S + M``
        elements: `scale_variances`).
    layout : ekf.StateLayout

    Returns
    -------
    dict of str to float
        ``yaw, pitch, roll`` (rad²; the pitch's with ``config.grade_sigma_rad``'s
        square added: a grade the track does not know), the IMU biases ((m/s²)²,
        (rad/s)²), ``clock_bias`` (m²), ``clock_drift`` (m²/s²), the layout's ``isb_*``
        (m²), the odometer's scale ``odo_scale`` (its prior,
        `railnav.filters.odometer_epochs.OdometerConfig`) and the IMU's mounting
        ``mount_*`` (rad², with ``config.track_attitude``).
    """
    imu, attitude = config.imu, config.initial_attitude_sigma_rad ** 2
    accel = max(imu.accel_bias_mps2 ** 2 + imu.accel_bias_instability_mps2 ** 2,
                _MIN_BIAS_VARIANCE)
    gyro = max(imu.gyro_bias_radps ** 2 + imu.gyro_bias_instability_radps ** 2,
               _MIN_BIAS_VARIANCE)
    pitch = attitude + config.grade_sigma_rad ** 2         # a grade the track does not know
    var = {"yaw": attitude, "pitch": pitch, "roll": attitude,
           CLOCK_STATE_NAMES[0]: config.initial_clock_bias_sigma_m ** 2,
           CLOCK_STATE_NAMES[1]: config.initial_clock_drift_sigma_mps ** 2}
    var.update({name: accel for name in BIAS_STATE_NAMES[:3]})
    var.update({name: gyro for name in BIAS_STATE_NAMES[3:]})
    var.update(scale_variances(imu, layout.names))
    var.update({name: config.initial_isb_sigma_m ** 2 for name in layout.names
                if name.startswith("isb_")})
    var[SCALE_STATE] = config.odometer_model.scale_sigma ** 2
    attitude_rows = getattr(config, "track_attitude", None)
    if attitude_rows is not None:      # the IMU's mounting (railnav.filters.attitude_rows)
        var.update({name: attitude_rows.mount_sigma_rad ** 2 for name in layout.names
                    if name.startswith("mount_")})
    return var


def scale_element_sigma(imu: ImuErrors, sensor: str, element: str) -> float:
    """σ of element `element` (``"<row><column>"``) of triad `sensor`'s ``S + M`` (``"a"``:
    accelerometer, ``"g"``: gyro) in the grade `imu`: its scale factor on the diagonal, its
    misalignment off it, dimensionless."""
    triad = "accel" if sensor == "a" else "gyro"
    return getattr(imu, f"{triad}_scale_factor_ppm") * 1e-6 if element[0] == element[1] \
        else getattr(imu, f"{triad}_misalignment_rad")


def scale_variances(imu: ImuErrors, names) -> dict[str, float]:
    """Prior variances of the ``S + M`` element states among `names`
    (`strapdown.kinematics.scale_state_name`, ``k_<sensor>_<row><col>``): the square of
    `scale_element_sigma`, floored at a tiny positive value."""
    return {name: max(scale_element_sigma(imu, name[2], name[4:]) ** 2, _MIN_BIAS_VARIANCE)
            for name in names if name.startswith(("k_a_", "k_g_")) and len(name) == 6}


def model_name(prefix: str, earth: Ellipsoid, biases: bool, isb: tuple[str, ...],
               extra: tuple[str, ...] = (), scale: tuple[str, ...] = ()) -> str:
    """An identifier naming a model's generated code (its cache key includes the source)."""
    radius = f"{earth.a_m:.0f}".replace(".", "_")
    return f"{prefix}_{earth.name}_{radius}{'_bias' if biases else ''}" \
           f"{'_isb' + ''.join(isb) if isb else ''}" + "".join(f"_{n}" for n in extra) \
        + "".join(f"_{n}" for n in scale)
