r"""The track-constrained filter's process model: reduced INS + receiver clock (+ biases).

State (`ekf.StateLayout`, names used everywhere; never indices)::

    [yaw, pitch, roll, s, v, (b_ax, b_ay, b_az, b_gx, b_gy, b_gz, (k_a_zy, k_g_zz)),
     clock_bias, clock_drift, (isb_<system> ...)]

angles rad, ``s`` m, ``v`` m/s, IMU biases m/s² and rad/s, receiver clock bias m (``c δt_r``)
and drift m/s, inter-system biases m (one per GNSS system after the first, e.g. ``isb_E``
for Galileo time against GPS time).

**Two elements of the IMU's ``S + M`` as states** (``k_a_zy``, ``k_g_zz``,
dimensionless, `SCALE_ELEMENTS`, `strapdown.kinematics.scale_state_name`), with the
biases, for a grade that has scale factors or misalignments (`scale_elements_for`): the
z accelerometer's misalignment towards y, ``M_zy``, which puts ``M_zy v²κ`` on the z axis
where the curvature steps (the normal row reads it as a roll), and the z gyro's scale
factor ``S_zz``, which puts ``S_zz vκ`` on the yaw rate. As states they step with the
*measured* input, at the truth's crossing; as `railnav.filters.scale_noise`'s random walk
(where every other element stays) they stepped at the filter's predicted crossing, and
the normal row tied the z bias again before the truth's step
(`docs/consistency-ablations.md`, circle_100mps and "Stop 28": 100 m/s on a 100-m circle,
10 seeds, NEES 12.85 → 9.14). Left to the random walk on purpose: the gyro's ``M_yz``
and ``M_xz`` (``vκ`` on the pitch and roll rates) and the accelerometer's ``M_xy``: as
states, their exact model made the 20-min outage's seed 5 confidently wrong (max |z_s|
9.6 → 29.5 with ``M_yz``; 25.5 with the branch that carried whole columns).

The INS part is `strapdown.reduced` (ARCHITECTURE.md
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
    scale_element_sigma,
)
from strapdown.imu_errors import ImuErrors
from strapdown.kinematics import SensorBiasStates
from strapdown.reduced import (
    REDUCED_STATE_NAMES,
    TRACK_PARAMETER_NAMES,
    build_reduced_model,
)
from trackmodel.earth import Ellipsoid

__all__ = ["ConstrainedModel", "build_constrained_model", "CLOCK_STATE_NAMES",
           "ISB_RANDOM_WALK_M2PS", "isb_state_name", "SCALE_ELEMENTS", "scale_elements_for"]

#: The constrained filter's model is an inertial model with the clock appended (the name
#: is kept for the readers of this module).
ConstrainedModel = InsClockModel

#: The elements ``"<row><column>"`` of the accelerometer's and the gyro's ``S + M`` that
#: the constrained filter estimates (module docstring): ``M_zy`` of the accelerometer,
#: ``S_zz`` of the gyro.
SCALE_ELEMENTS = (("zy",), ("zz",))


def scale_elements_for(*, biases_estimated: bool, imu: ImuErrors
                       ) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The elements of `SCALE_ELEMENTS` (accelerometer, gyro) whose σ in the grade the
    filter assumes (`imu`, `ins_clock_model.scale_element_sigma`) is not 0, when the state
    carries the IMU biases; else none."""
    if not biases_estimated:
        return (), ()
    return tuple(tuple(e for e in elements if scale_element_sigma(imu, sensor, e) > 0.0)
                 for sensor, elements in zip("ag", SCALE_ELEMENTS))


@functools.lru_cache(maxsize=None)
def build_constrained_model(earth: Ellipsoid, *, estimate_biases: bool = False,
                            isb_systems: tuple[str, ...] = (),
                            extra_blocks: tuple = (),
                            scale_elements: tuple = ((), ())) -> InsClockModel:
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
    scale_elements : (tuple of str, tuple of str)
        Accelerometer and gyro elements of ``S + M`` that are states (with
        `estimate_biases`; `scale_elements_for`).

    Returns
    -------
    InsClockModel
        ``f(x, u, p)``, ``G``, ``h_c``, ``D`` with ``u = [f_b, ω_ib_b]`` (6) and ``p`` the
        16 track parameters of `strapdown.reduced.TRACK_PARAMETER_NAMES`.
    """
    biases = SensorBiasStates(math.inf, math.inf, *scale_elements) if estimate_biases \
        else None
    reduced = build_reduced_model(earth, biases)
    scale_names = biases.scale_names() if biases is not None else ()
    return assemble_ins_clock_model(
        [("attitude", REDUCED_STATE_NAMES[:3]), ("s", 1), ("v", 1)], reduced.f, reduced.G,
        ins_h_c=reduced.h_c, ins_D=reduced.D, earth=earth, estimate_biases=estimate_biases,
        isb_systems=tuple(isb_systems), n_p=len(TRACK_PARAMETER_NAMES),
        extra_blocks=tuple(extra_blocks), scale_names=scale_names,
        name=model_name("railnav", earth, estimate_biases, tuple(isb_systems),
                        tuple(n for _, names in extra_blocks for n in names), scale_names))
