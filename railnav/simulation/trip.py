"""A simulated trip: truth, IMU and GNSS measurements of one scenario on one track.

`simulate_trip` is the one simulation path behind ``railnav simulate`` (which writes the
files) and ``railnav run TRACK`` without sensor files (which filters them in memory). The
GNSS receiver is at the scenario's antenna lever arm from the track reference point
(`Scenario.antenna_m`, default none); its epochs are IMU sample
times at the scenario's GNSS rate, from GPS time `Scenario.start_gps_time_s`; outages are
the scenario's (s from the trip start). Random streams are independent per sensor
(`railnav.simulation.scenarios.RNG_STREAMS`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import numpy.typing as npt

from gnss_obs.measurements import MeasurementConfig
from gnss_obs.rinex_nav import RinexNav, read_rinex_nav
from gnss_obs.sim_events import SatelliteFault
from gnss_obs.simulate import (
    GnssSimConfig,
    GnssSimulation,
    default_nav_path,
    simulate_gnss,
)
from railnav.config import DEFAULT_FILTER, DEFAULT_SYSTEMS, NavigatorConfig
from railnav.defaults import DEFAULT_SEED
from railnav.errors import ConfigError
from railnav.evaluation.metrics import check_trip_times
from railnav.filters.track_frame import LeverArms
from railnav.sensor_data import SensorData
from railnav.simulation.scenarios import (
    RNG_STREAMS,
    Scenario,
    SimulationResult,
    simulate_scenario,
)
from railnav.simulation.track_sensors import (
    antenna_track,
    sensor_models_from_simulation,
)
from strapdown.imu_errors import ImuErrors

__all__ = ["SimulatedTrip", "simulate_trip", "navigator_config_for", "gnss_sim_config_for",
           "navigator_config_from_simulation"]

Array = npt.NDArray[np.float64]



@dataclass(frozen=True, eq=False)
class SimulatedTrip:
    """Everything known about a simulated trip.

    Attributes
    ----------
    scenario : Scenario
    simulation : railnav.simulation.scenarios.SimulationResult
        Track, truth, ideal and measured IMU.
    gnss : gnss_obs.GnssSimulation or None
        Observations and the receiver clock truth.
    nav : gnss_obs.RinexNav or None
        The broadcast navigation data the GNSS simulation used.
    systems : str
    seed : int
        The random seed it was simulated with (`simulate_trip`).
    """

    scenario: Scenario
    simulation: SimulationResult
    gnss: GnssSimulation | None
    nav: RinexNav | None
    systems: str
    seed: int = DEFAULT_SEED

    @property
    def track(self):
        """The trip's `trackmodel.Track`."""
        return self.simulation.track

    @property
    def truth(self):
        """The true trajectory (`railnav.simulation.truth.Truth`)."""
        return self.simulation.truth

    def sensor_data(self) -> SensorData:
        """The measurements as the navigator takes them."""
        obs = None if self.gnss is None else self.gnss.obs
        return SensorData(self.scenario.start_gps_time_s, imu=self.simulation.imu_measured,
                          obs=obs, nav=self.nav if obs is not None else None)

    def clock_truth(self, time_s: npt.ArrayLike) -> tuple[Array, Array]:
        """True receiver clock bias (m) and drift (m/s) at times from the trip start."""
        t = np.asarray(time_s, dtype=float)
        if self.gnss is None:
            return np.zeros_like(t), np.zeros_like(t)
        clock = self.gnss.clock
        t_clock = clock["gps_time_s"].to_numpy() - self.scenario.start_gps_time_s
        return (np.interp(t, t_clock, clock["clock_bias_m"].to_numpy()),
                np.interp(t, t_clock, clock["clock_drift_mps"].to_numpy()))


def gnss_sim_config_for(scenario: Scenario, *, systems: str = DEFAULT_SYSTEMS,
                        faults: tuple[SatelliteFault, ...] = ()) -> GnssSimConfig:
    """The GNSS simulator settings of a scenario (its σ, multipath, clock and outages)."""
    return GnssSimConfig(systems=systems, sigma_pr_m=scenario.sigma_pseudorange_m,
                         sigma_rr_mps=scenario.sigma_range_rate_mps, oscillator=scenario.clock,
                         multipath_sigma_m=scenario.multipath_sigma_m,
                         multipath_tau_s=scenario.multipath_tau_s,
                         outages=scenario.outages, faults=tuple(faults),
                         time_origin_gps_time_s=scenario.start_gps_time_s)


def navigator_config_for(scenario: Scenario, *, filter: str = DEFAULT_FILTER,
                         systems: str = DEFAULT_SYSTEMS, **overrides) -> NavigatorConfig:
    """A navigator that assumes what the scenario simulates (IMU grade, clock, GNSS σ, the
    antenna's lever arm, a car body's suspension: ``suspension_noise``).

    The GNSS σ are the simulator's constant ones (no elevation or C/N0 weighting); the
    initial σ of ``s`` and ``v`` are the scenario's initial errors. `overrides` replace
    any other `NavigatorConfig` field.
    """
    config = _simulated_sensor_config(
        filter=filter, systems=systems, imu_errors=scenario.imu_errors,
        clock=scenario.clock, sigma_pr_m=scenario.sigma_pseudorange_m,
        sigma_rr_mps=scenario.sigma_range_rate_mps,
        initial=(scenario.initial_attitude_sigma_rad, scenario.initial_s_sigma_m,
                 scenario.initial_v_sigma_mps))
    if any(scenario.antenna_m):
        config = replace(config, lever_arms=LeverArms(antenna_m=scenario.antenna_m))
    if scenario.car_body is not None:
        config = replace(config, suspension_noise=True)
    return replace(config, **overrides)


def navigator_config_from_simulation(meta: dict, *, filter: str = DEFAULT_FILTER,
                                     **overrides) -> NavigatorConfig:
    """`navigator_config_for` from the ``scenario.json`` that ``railnav simulate`` writes
    (``suspension_noise`` when it simulated a car body).

    Parameters
    ----------
    meta : dict
        The parsed ``scenario.json`` (keys ``scenario`` and ``gnss_systems``).
    filter : str
    overrides
        Other `NavigatorConfig` fields.

    Raises
    ------
    ConfigError
        For a file without the sensor settings.
    """
    try:
        sc = meta["scenario"]
        imu = ImuErrors(**sc["imu_errors"])
        config = _simulated_sensor_config(
            filter=filter, systems=meta.get("gnss_systems") or DEFAULT_SYSTEMS, imu_errors=imu,
            clock=sc["clock"], sigma_pr_m=float(sc["sigma_pseudorange_m"]),
            sigma_rr_mps=float(sc["sigma_range_rate_mps"]),
            initial=(float(sc["initial_attitude_sigma_rad"]), float(sc["initial_s_sigma_m"]),
                     float(sc["initial_v_sigma_mps"])))
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"scenario.json lacks the sensor settings: {exc}") from None
    if sc.get("car_body") is not None:
        config = replace(config, suspension_noise=True)
    return replace(config, **{**sensor_models_from_simulation(meta), **overrides})


def _simulated_sensor_config(*, filter: str, systems: str, imu_errors, clock: str,
                             sigma_pr_m: float, sigma_rr_mps: float,
                             initial: tuple[float, float, float]) -> NavigatorConfig:
    measurement = MeasurementConfig(systems=systems, sigma_pr_m=sigma_pr_m,
                                    sigma_rr_mps=sigma_rr_mps, elevation_weighting=False,
                                    cn0_ref_dbhz=math.nan)
    base = NavigatorConfig(filter=filter, imu_errors=imu_errors, oscillator=clock,
                           measurement=measurement, initial_attitude_sigma_rad=initial[0],
                           initial_s_sigma_m=initial[1], initial_v_sigma_mps=initial[2],
                           pseudorange_correlation_s=0.0,   # the simulator's errors are white
                           track_heading_sigma_rad=0.0)     # and its velocity is v t(s)
    return base


def simulate_trip(scenario: Scenario, *, track=None, seed: int = DEFAULT_SEED, gnss: bool = True,
                  systems: str = DEFAULT_SYSTEMS, faults: tuple[SatelliteFault, ...] = (),
                  nav: RinexNav | None = None,
                  progress: Callable[[int, int], None] | None = None) -> SimulatedTrip:
    """Simulate truth, IMU and (optionally) GNSS for a scenario.

    Parameters
    ----------
    scenario : Scenario
    track : trackmodel.Track or path, optional
        Default: the scenario's track.
    seed : int
    gnss : bool
        Simulate GNSS observations.
    systems : str
        GNSS systems to simulate.
    faults : tuple of gnss_obs.SatelliteFault
        Satellite faults (times from the trip start).
    nav : gnss_obs.RinexNav, optional
        Constellation; default the shipped 2020-11-29 broadcast file.
    progress : callable(done, total), optional

    Returns
    -------
    SimulatedTrip

    Raises
    ------
    ConfigError
        If the GNSS rate does not divide the IMU rate, or an outage starts after the trip
        ends (`railnav.evaluation.metrics.check_trip_times`).
    """
    sim = simulate_scenario(scenario, track=track, seed=seed, progress=progress)
    end_s = float(sim.truth.time_s[-1])
    early = end_s < scenario.duration_s - 1.0 / scenario.imu_rate_hz
    check_trip_times(end_s, outages=scenario.outages,
                     early_end="at the track's end" if early else "")
    if not gnss:
        return SimulatedTrip(scenario, sim, None, None, systems, seed)
    ratio = scenario.imu_rate_hz / scenario.gnss_rate_hz
    step = int(round(ratio))
    if step < 1 or abs(ratio - step) > 1e-9:
        raise ConfigError(f"the GNSS rate ({scenario.gnss_rate_hz} Hz) must divide the IMU "
                          f"rate ({scenario.imu_rate_hz} Hz)")
    nav = nav if nav is not None else read_rinex_nav(default_nav_path())
    epochs = sim.truth.rows(slice(0, None, step))     # the receiver's epochs only
    rng = np.random.default_rng(sim.rng_streams[RNG_STREAMS["gnss"]])
    r_e, v_e = antenna_track(sim.track, epochs, scenario.antenna_m)
    obs = simulate_gnss(scenario.start_gps_time_s + epochs.time_s, r_e, v_e,
                        nav, gnss_sim_config_for(scenario, systems=systems, faults=faults),
                        rng=rng)
    return SimulatedTrip(scenario, sim, obs, nav, systems, seed)
