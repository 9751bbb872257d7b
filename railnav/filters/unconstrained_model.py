r"""The unconstrained filter's process model: full 9-state INS + receiver clock (+ biases).

State (`ekf.StateLayout`, names used everywhere; never indices)::

    [yaw, pitch, roll, v_E, v_N, v_U, lat, lon, h, (b_ax, b_ay, b_az, b_gx, b_gy, b_gz),
     clock_bias, clock_drift, (isb_<system> ...)]

angles rad, ENU velocity relative to the Earth m/s, geodetic latitude and longitude rad,
ellipsoidal height m; biases, clock and inter-system biases as in
`railnav.filters.ins_clock_model`. The INS part is the free-inertial mechanization of
`strapdown.mechanization` (ARCHITECTURE.md "Physics"); nothing ties the vehicle to a
track: there is no continuous pseudo-observation and no per-step parameter (``p`` is
empty). Noise and its densities are those of the constrained filter for the same
configuration (`railnav.filters.ins_clock_model.InsClockModel.process_noise_density`): the IMU
white noise through the inputs (``G = −∂f/∂u``), bias random walks, the clock.
"""
from __future__ import annotations

import functools
import math

from railnav.filters.ins_clock_model import (
    InsClockModel,
    assemble_ins_clock_model,
    model_name,
)
from strapdown.kinematics import SensorBiasStates
from strapdown.mechanization import FULL_STATE_NAMES, build_full_model
from trackmodel.earth import Ellipsoid

__all__ = ["build_unconstrained_model", "NAV_BLOCKS", "POSITION_STATE_NAMES",
           "VELOCITY_STATE_NAMES"]

#: Velocity states (ENU, m/s) and geodetic position states (rad, rad, m) of the layout.
VELOCITY_STATE_NAMES = FULL_STATE_NAMES[3:6]
POSITION_STATE_NAMES = FULL_STATE_NAMES[6:9]
#: The navigation blocks of the layout, in the mechanization's order.
NAV_BLOCKS = (("attitude", FULL_STATE_NAMES[:3]), ("velocity", VELOCITY_STATE_NAMES),
              ("position", POSITION_STATE_NAMES))


@functools.lru_cache(maxsize=None)
def build_unconstrained_model(earth: Ellipsoid, *, estimate_biases: bool = False,
                              isb_systems: tuple[str, ...] = ()) -> InsClockModel:
    """Build (once per argument set) the unconstrained filter's process model.

    Parameters
    ----------
    earth : Ellipsoid
        The Earth model of the mechanization (gravity, radii, rotation).
    estimate_biases : bool
        Add accelerometer and gyro bias states (random walks).
    isb_systems : tuple of str
        GNSS systems that get an inter-system bias state.

    Returns
    -------
    InsClockModel
        ``f(x, u, p)`` and ``G`` with ``u = [f_b, ω_ib_b]`` (6) and an empty ``p``.
    """
    full = build_full_model(earth, SensorBiasStates(math.inf, math.inf)
                            if estimate_biases else None)
    return assemble_ins_clock_model(
        NAV_BLOCKS, lambda x, u, p: full.f(x, u), lambda x, u, p: full.G(x, u),
        earth=earth, estimate_biases=estimate_biases, isb_systems=tuple(isb_systems), n_p=0,
        name=model_name("railnav_full", earth, estimate_biases, tuple(isb_systems)))
