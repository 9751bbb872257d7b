r"""The track-constrained filter's process model: reduced INS + receiver clock (+ biases).

State (`ekf.StateLayout`, names used everywhere; never indices)::

    [yaw, pitch, roll, s, v, (b_ax, b_ay, b_az, b_gx, b_gy, b_gz), clock_bias, clock_drift,
     (isb_<system> ...)]

angles rad, ``s`` m, ``v`` m/s, IMU biases m/s² and rad/s, receiver clock bias m (``c δt_r``)
and drift m/s, inter-system biases m (one per GNSS system after the first, e.g. ``isb_E``
for Galileo time against GPS time). The INS part is `strapdown.reduced` (ARCHITECTURE.md
"Physics"): its accelerometer pseudo-observation ``h_c`` (2 components, m/s²) is the
continuous measurement, sampled at every IMU step with value 0.

Noise ``w``, its spectral densities and the bias, clock and inter-system-bias states are
those of every inertial filter (`railnav.filters.ins_clock_model`). The pseudo-observation noise
``D = −∂h_c/∂u`` shares ``w_f`` with the process noise ``G = −∂f/∂u`` (the paper's
eq. 14 correlated noise); for an isotropic accelerometer the cross-covariance vanishes
because ``u ⊥ P⊥``, but nothing here assumes it.
"""
from __future__ import annotations

import functools
import math

from railnav.filters.ins_clock_model import (
    CLOCK_STATE_NAMES,
    ISB_RANDOM_WALK_M2PS,
    InsClockModel,
    assemble_ins_clock_model,
    isb_state_name,
    model_name,
)
from strapdown.kinematics import SensorBiasStates
from strapdown.reduced import (
    REDUCED_STATE_NAMES,
    TRACK_PARAMETER_NAMES,
    build_reduced_model,
)
from trackmodel.earth import Ellipsoid

__all__ = ["ConstrainedModel", "build_constrained_model", "CLOCK_STATE_NAMES",
           "ISB_RANDOM_WALK_M2PS", "isb_state_name"]

#: The constrained filter's model is an inertial model with the clock appended (the name
#: is kept for the readers of this module).
ConstrainedModel = InsClockModel


@functools.lru_cache(maxsize=None)
def build_constrained_model(earth: Ellipsoid, *, estimate_biases: bool = False,
                            isb_systems: tuple[str, ...] = (),
                            extra_blocks: tuple = ()) -> InsClockModel:
    """Build (once per argument set) the constrained filter's process model.

    Parameters
    ----------
    earth : Ellipsoid
        The track's Earth model (gravity, radii, rotation).
    estimate_biases : bool
        Add accelerometer and gyro bias states.
    isb_systems : tuple of str
        GNSS systems that get an inter-system bias state.
    extra_blocks : tuple of (str, tuple of str)
        Further random-walk states (`railnav.filters.sensor_rows.sensor_states`).

    Returns
    -------
    InsClockModel
        ``f(x, u, p)``, ``G``, ``h_c``, ``D`` with ``u = [f_b, ω_ib_b]`` (6) and ``p`` the
        16 track parameters of `strapdown.reduced.TRACK_PARAMETER_NAMES`.
    """
    reduced = build_reduced_model(earth, SensorBiasStates(math.inf, math.inf)
                                  if estimate_biases else None)
    return assemble_ins_clock_model(
        [("attitude", REDUCED_STATE_NAMES[:3]), ("s", 1), ("v", 1)], reduced.f, reduced.G,
        ins_h_c=reduced.h_c, ins_D=reduced.D, earth=earth, estimate_biases=estimate_biases,
        isb_systems=tuple(isb_systems), n_p=len(TRACK_PARAMETER_NAMES),
        extra_blocks=tuple(extra_blocks),
        name=model_name("railnav", earth, estimate_biases, tuple(isb_systems),
                        tuple(n for _, names in extra_blocks for n in names)))
