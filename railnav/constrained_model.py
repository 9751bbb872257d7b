r"""The track-constrained filter's process model: reduced INS + receiver clock (+ biases).

State (`ekf.StateLayout`, names used everywhere; never indices)::

    [yaw, pitch, roll, s, v, (b_ax, b_ay, b_az, b_gx, b_gy, b_gz), clock_bias, clock_drift,
     (isb_<system> ...)]

angles rad, ``s`` m, ``v`` m/s, IMU biases m/s² and rad/s, receiver clock bias m (``c δt_r``)
and drift m/s, inter-system biases m (one per GNSS system after the first, e.g. ``isb_E``
for Galileo time against GPS time). The INS part is `strapdown.reduced` (ARCHITECTURE.md
"Physics"): its accelerometer pseudo-observation ``h_c`` (2 components, m/s²) is the
continuous measurement, sampled at every IMU step with value 0.

Noise ``w`` (spectral densities ``q_c``, `process_noise_density`)::

    [w_f (3, (m/s²)²·s), w_ω (3, (rad/s)²·s), (w_ba (3), w_bg (3)), w_b (m²/s), w_d (m²/s³),
     (w_isb (m²/s) ...)]

The IMU white noise is an error of the measured input, so it enters the dynamics as
``G = −∂f/∂u`` and the pseudo-observation as ``D = −∂h_c/∂u`` (the SAME ``w_f``: the paper's
eq. 14 correlated noise; for an isotropic accelerometer the cross-covariance vanishes
because ``u ⊥ P⊥``, but nothing here assumes it). IMU biases are random walks
(``ḃ = w``) whose density ``2σ²/τ`` matches the Gauss–Markov bias instability of the
grade over times short against ``τ``, plus a constant part carried by the initial
covariance. The clock is the two-state oscillator model of `gnss_obs.oscillator`.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import CdModel
from gnss_obs.oscillator import Oscillator
from strapdown.imu_errors import ImuErrors
from strapdown.kinematics import BIAS_STATE_NAMES, INPUT_NAMES, SensorBiasStates
from strapdown.reduced import REDUCED_STATE_NAMES, TRACK_PARAMETER_NAMES, build_reduced_model
from trackmodel.earth import Ellipsoid

__all__ = ["ConstrainedModel", "build_constrained_model", "CLOCK_STATE_NAMES",
           "ISB_RANDOM_WALK_M2PS", "isb_state_name"]

Array = npt.NDArray[np.float64]

#: Receiver clock states: bias (m) and drift (m/s).
CLOCK_STATE_NAMES = ("clock_bias", "clock_drift")
#: Spectral density of the inter-system bias random walk, m²/s (a slowly wandering
#: GPS-Galileo time offset of the receiver: ~0.3 m per hour).
ISB_RANDOM_WALK_M2PS = 1e-5
#: Bias random walks are kept strictly positive so that the covariance stays definite.
_MIN_BIAS_DENSITY = 1e-30


def isb_state_name(system: str) -> str:
    """State name of the inter-system bias of a GNSS system letter (``"E"`` -> ``isb_E``)."""
    return f"isb_{system}"


@dataclass(frozen=True, eq=False)
class ConstrainedModel:
    """The constrained filter's process model (see the module docstring).

    Attributes
    ----------
    process : ekf.CdModel
        ``f(x, u, p)``, ``G``, ``h_c``, ``D`` with ``u = [f_b, ω_ib_b]`` (6) and ``p`` the
        16 track parameters of `strapdown.reduced.TRACK_PARAMETER_NAMES`.
    layout : ekf.StateLayout
    earth : Ellipsoid
    estimate_biases : bool
    isb_systems : tuple of str
        Systems with an inter-system bias state.
    noise_names : tuple of str
        Names of the components of ``w`` (and of `process_noise_density`).
    """

    process: CdModel
    layout: StateLayout
    earth: Ellipsoid
    estimate_biases: bool
    isb_systems: tuple[str, ...]
    noise_names: tuple[str, ...]

    def process_noise_density(self, imu: ImuErrors, oscillator: Oscillator) -> Array:
        """Diagonal spectral density ``q_c`` of ``w`` (units in the module docstring).

        Parameters
        ----------
        imu : ImuErrors
            The IMU grade the filter assumes.
        oscillator : Oscillator
            The receiver clock the filter assumes.

        Returns
        -------
        ndarray, shape (n_w,)
        """
        q = [imu.accel_noise_density_mps2_rthz ** 2] * 3 + \
            [imu.gyro_noise_density_radps_rthz ** 2] * 3
        if self.estimate_biases:
            q += [_random_walk_density(imu.accel_bias_instability_mps2, imu.accel_bias_tau_s)] * 3
            q += [_random_walk_density(imu.gyro_bias_instability_radps, imu.gyro_bias_tau_s)] * 3
        q += [oscillator.q_bias_m2ps, oscillator.q_drift_m2ps3]
        q += [ISB_RANDOM_WALK_M2PS] * len(self.isb_systems)
        return np.array(q, dtype=float)


def _random_walk_density(sigma: float, tau_s: float) -> float:
    """``2σ²/τ``: the random walk that follows a Gauss–Markov process for ``t ≪ τ``."""
    return max(2.0 * sigma * sigma / tau_s, _MIN_BIAS_DENSITY)


@functools.lru_cache(maxsize=None)
def build_constrained_model(earth: Ellipsoid, *, estimate_biases: bool = False,
                            isb_systems: tuple[str, ...] = ()) -> ConstrainedModel:
    """Build (once per argument set) the constrained filter's process model.

    Parameters
    ----------
    earth : Ellipsoid
        The track's Earth model (gravity, radii, rotation).
    estimate_biases : bool
        Add accelerometer and gyro bias states.
    isb_systems : tuple of str
        GNSS systems that get an inter-system bias state.

    Returns
    -------
    ConstrainedModel
    """
    reduced = build_reduced_model(earth, SensorBiasStates(math.inf, math.inf)
                                  if estimate_biases else None)
    n_red = len(reduced.layout.names)
    blocks = [("attitude", REDUCED_STATE_NAMES[:3]), ("s", 1), ("v", 1)]
    if estimate_biases:
        blocks.append(("imu_bias", BIAS_STATE_NAMES))
    blocks.append(("clock", CLOCK_STATE_NAMES))
    if isb_systems:
        blocks.append(("isb", tuple(isb_state_name(s) for s in isb_systems)))
    layout = StateLayout.from_blocks(blocks)

    x = ca.SX.sym("x", layout.size)
    u = ca.SX.sym("u", len(INPUT_NAMES))
    p = ca.SX.sym("p", len(TRACK_PARAMETER_NAMES))
    x_red = x[:n_red]
    i_b, i_d = layout.index("clock_bias"), layout.index("clock_drift")
    n_isb = len(isb_systems)
    xdot = ca.vertcat(reduced.f(x_red, u, p), x[i_d], 0.0, ca.SX.zeros(n_isb))

    # Noise input map: IMU noise through the inputs, then one column per random-walk state.
    walk_states = list(range(5, n_red)) + [i_b, i_d] + list(range(layout.size - n_isb,
                                                                   layout.size))
    G_imu = ca.vertcat(-reduced.G(x_red, u, p), ca.SX.zeros(layout.size - n_red, 6))
    G_walk = ca.SX.zeros(layout.size, len(walk_states))
    for col, row in enumerate(walk_states):
        G_walk[row, col] = 1.0
    h_c = reduced.h_c(x_red, u, p)
    D = ca.horzcat(-reduced.D(x_red, u, p), ca.SX.zeros(2, len(walk_states)))
    process = CdModel.from_expressions(layout, x, u, p, xdot, h_c=h_c,
                                       G=ca.horzcat(G_imu, G_walk), D=D,
                                       name=_model_name(earth, estimate_biases, isb_systems))
    noise_names = ("w_fx", "w_fy", "w_fz", "w_wx", "w_wy", "w_wz") + tuple(
        f"w_{layout.names[i]}" for i in walk_states)
    return ConstrainedModel(process=process, layout=layout, earth=earth,
                            estimate_biases=estimate_biases, isb_systems=tuple(isb_systems),
                            noise_names=noise_names)


def _model_name(earth: Ellipsoid, biases: bool, isb: tuple[str, ...]) -> str:
    """An identifier naming the generated code (its cache key includes the source)."""
    radius = f"{earth.a_m:.0f}".replace(".", "_")
    return f"railnav_{earth.name}_{radius}{'_bias' if biases else ''}" \
           f"{'_isb' + ''.join(isb) if isb else ''}"
