"""Named scenarios (speed profile + sensors) and the simulation of a scenario on a track.

A `Scenario` is applicable to any track: it says how the train moves (a `SpeedProfile`
and a duration), what the IMU is (rate and error grade), what initial errors a filter
starts with, and the GNSS settings the GNSS simulator uses. `SCENARIOS` holds the named
ones; build others with ``dataclasses.replace(get_scenario("curvy"), ...)`` or from
scratch. `simulate_scenario` produces the truth and the ideal and measured IMU records.

Random numbers: ``numpy.random.SeedSequence(seed).spawn(4)`` gives independent streams,
child 0 for the IMU errors, child 1 for GNSS measurements, child 2 for initial errors,
child 3 for GNSS position fixes, so adding or changing one sensor does not change the
others' draws.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from railnav_data import TRACKS, shipped_path

from gnss_obs.errors import GnssError
from gnss_obs.sim_defaults import (
    DEFAULT_START_GPS_TIME_S,
    PAPER_SIGMA_PR_M,
    PAPER_SIGMA_RR_MPS,
)
from gnss_obs.sim_events import Outage
from railnav.defaults import DEFAULT_IMU_GRADE
from railnav.errors import ConfigError
from railnav.simulation.car_body_config import CarBodyMotion
from railnav.simulation.profiles import (
    SpeedProfile,
    constant_speed,
    station_stop_profile,
)
from strapdown.errors import StrapdownError
from strapdown.imu_errors import ImuErrors, apply_imu_errors, imu_grade

if TYPE_CHECKING:
    from railnav.simulation.truth import Truth
    from strapdown.imu import Imu

__all__ = ["Scenario", "SimulationResult", "SCENARIOS", "get_scenario", "scenario_for_track",
           "DEFAULT_SCENARIO", "simulate_scenario",
           "TRACKS_DIR", "DEFAULT_START_GPS_TIME_S", "scenario_to_dict", "RNG_STREAMS"]

log = logging.getLogger(__name__)

#: Example tracks shipped with the repository.
TRACKS_DIR = shipped_path(TRACKS)
#: 2020-11-29 12:40:00 GPST: inside the validity of the shipped broadcast navigation file.
#: Indices of the independent random streams spawned from the seed (a stream added at the
#: end leaves the others' draws unchanged: ``SeedSequence.spawn`` children are numbered).
RNG_STREAMS = {"imu": 0, "gnss": 1, "initial": 2, "fixes": 3, "imu_log": 4, "odometer": 5,
               "balises": 6, "baro": 7, "car_body": 8}


@dataclass(frozen=True)
class Scenario:
    """A trip's motion and sensors, independent of the track.

    Parameters
    ----------
    name : str
    profile : SpeedProfile
        Speed versus time from the trip start.
    duration_s : float
        Trip duration, s (the trip ends at the track end at the latest).
    imu_rate_hz : float
        IMU sample rate, Hz.
    imu_errors : str or ImuErrors
        IMU grade preset name (`strapdown.imu_errors.IMU_GRADES`) or parameters.
    default_track : str or None
        File name in `TRACKS_DIR` of the track the scenario was designed for.
    start_s : float
        Along-track distance at t = 0, m.
    initial_attitude_sigma_rad, initial_s_sigma_m, initial_v_sigma_mps : float
        1σ initial errors a filter starts with: rad, m, m/s.
    gnss_rate_hz : float
        GNSS epoch rate, Hz.
    sigma_pseudorange_m, sigma_range_rate_mps : float
        1σ GNSS measurement noise: m, m/s.
    outages : tuple of gnss_obs.Outage (or (start_s, duration_s) pairs, converted)
        GNSS outages, seconds from the trip start.
    start_gps_time_s : float
        GPS time of the trip start, s since 1980-01-06.
    clock : str
        Receiver clock preset name (GNSS simulator).
    antenna_m : (float, float, float)
        The GNSS antenna's lever arm from the reference point: forward, left, up, m
        (`railnav.filters.track_frame`); the receiver is simulated there.
    car_body : CarBodyMotion or None
        The IMU on a car body: chord between bogies, suspension motion, mounting
        (`railnav.simulation.car_body_motion`; the ``car_body`` random stream). None
        (default): the IMU's attitude is the track's.
    multipath_sigma_m, multipath_tau_s : float
        Code multipath: the steady-state σ (m, >= 0; 0: none) and correlation time (s, > 0)
        of a first-order Gauss–Markov bias per satellite, scaled by ``1/sin(elevation)``
        (`gnss_obs.simulate.GnssSimConfig`); on top of the white σ_pr.
    """

    name: str
    profile: SpeedProfile
    duration_s: float
    imu_rate_hz: float = 100.0
    imu_errors: str | ImuErrors = DEFAULT_IMU_GRADE
    default_track: str | None = None
    start_s: float = 0.0
    initial_attitude_sigma_rad: float = 1e-3
    initial_s_sigma_m: float = 5.0
    initial_v_sigma_mps: float = 0.1
    gnss_rate_hz: float = 1.0
    sigma_pseudorange_m: float = PAPER_SIGMA_PR_M
    sigma_range_rate_mps: float = PAPER_SIGMA_RR_MPS
    outages: tuple[Outage, ...] = ()
    start_gps_time_s: float = DEFAULT_START_GPS_TIME_S
    clock: str = "tcxo"
    antenna_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    car_body: CarBodyMotion | None = None
    multipath_sigma_m: float = 0.0
    multipath_tau_s: float = 60.0

    def __post_init__(self) -> None:
        positive = ("duration_s", "imu_rate_hz", "gnss_rate_hz", "sigma_pseudorange_m",
                    "sigma_range_rate_mps")
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.multipath_tau_s) and self.multipath_tau_s > 0):
            raise ConfigError(f"multipath_tau_s must be finite and > 0, got "
                              f"{self.multipath_tau_s!r}")
        for name in ("start_s", "initial_attitude_sigma_rad", "initial_s_sigma_m",
                     "initial_v_sigma_mps", "multipath_sigma_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be finite and >= 0, got {value!r}")
        try:
            outages = tuple(Outage.of(o) for o in self.outages)
        except (GnssError, TypeError) as exc:
            raise ConfigError(f"outages must be (start_s >= 0, duration_s > 0), got "
                              f"{self.outages!r} ({exc})") from None
        if any(not (a >= 0 and b > 0 and math.isfinite(a + b)) for a, b in outages):
            raise ConfigError(f"outages must be (start_s >= 0, duration_s > 0), got "
                              f"{[tuple(o) for o in outages]}")
        object.__setattr__(self, "outages", outages)
        arm = tuple(self.antenna_m)
        if len(arm) != 3 or not all(math.isfinite(a) and abs(a) <= 100 for a in arm):
            raise ConfigError(f"antenna_m must be 3 finite offsets within ±100 m, got {arm!r}")
        object.__setattr__(self, "antenna_m", tuple(float(a) for a in arm))
        if not (self.car_body is None or isinstance(self.car_body, CarBodyMotion)):
            raise ConfigError(f"car_body must be a CarBodyMotion or None, got "
                              f"{self.car_body!r}")
        try:
            imu_grade(self.imu_errors)
        except StrapdownError as exc:
            raise ConfigError(str(exc)) from None

    @property
    def imu(self) -> ImuErrors:
        """The IMU error parameters."""
        return imu_grade(self.imu_errors)

    def with_overrides(self, *, speed_mps: float | None = None,
                       duration_s: float | None = None,
                       imu_errors: str | ImuErrors | None = None,
                       outages: tuple | None = None) -> "Scenario":
        """The scenario with what is given replaced (None: kept): `speed_mps`, the
        profile's top speed (m/s, scaling all speeds), `duration_s` (s), `imu_errors` (the
        IMU grade), `outages` (s from the trip start). The one place where ``railnav
        simulate`` and ``railnav run`` apply their flags to a scenario.

        A shorter duration drops the scenario's own outages that start after it (they
        belong to the longer trip); given `outages` are kept as given, and a run refuses
        one that starts after its trip ends (`railnav.evaluation.metrics.check_trip_times`).
        """
        out = self
        if speed_mps is not None:
            out = replace(out, profile=out.profile.scaled_to(speed_mps))
        if duration_s is not None:
            kept = tuple(o for o in out.outages if Outage.of(o).start_s < duration_s)
            out = replace(out, duration_s=duration_s, outages=kept)
        if imu_errors is not None:
            out = replace(out, imu_errors=imu_errors)
        if outages is not None:
            out = replace(out, outages=tuple(outages))
        return out


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """The scenario's parameters as JSON-ready data (IMU errors expanded)."""
    data = asdict(scenario)
    data["imu_errors"] = asdict(scenario.imu)
    data["outages"] = [list(o) for o in scenario.outages]
    if scenario.car_body is None:
        data.pop("car_body")
    if scenario.multipath_sigma_m == 0.0:           # none simulated: no entries
        data.pop("multipath_sigma_m")
        data.pop("multipath_tau_s")
    return data


SCENARIOS: dict[str, Scenario] = {
    "paper2017": Scenario(
        name="paper2017", profile=constant_speed(20.0), duration_s=1000.0,
        imu_rate_hz=100.0, imu_errors="paper2017", default_track="paper2017.csv",
        sigma_pseudorange_m=PAPER_SIGMA_PR_M, sigma_range_rate_mps=PAPER_SIGMA_RR_MPS,
        outages=((100.0, 50.0), (500.0, 50.0))),
    "curvy": Scenario(
        name="curvy", duration_s=1000.0, imu_errors="tactical", default_track="curvy.csv",
        profile=station_stop_profile(cruise_speed_mps=25.0, accel_time_s=60.0,
                                     brake_time_s=50.0, cruise_before_stop_s=300.0,
                                     dwell_s=60.0, start_dwell_s=10.0)),
}


def get_scenario(name: str) -> Scenario:
    """The named scenario.

    Raises
    ------
    ConfigError
        For an unknown name.
    """
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ConfigError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)}") from None


#: The scenario simulated on a track whose file name is not a scenario's name.
DEFAULT_SCENARIO = "curvy"


def scenario_for_track(track, name: str | None = None) -> Scenario:
    """The scenario simulated on the track file `track`: `name` if given, else the one
    named as the file's stem (``paper2017.csv``: ``paper2017``) if there is one, else
    `DEFAULT_SCENARIO` (``railnav run TRACK`` and ``railnav simulate TRACK`` without
    ``--scenario``).

    Raises
    ------
    ConfigError
        An unknown `name`.
    """
    if name is None:
        stem = Path(track).stem
        name = stem if stem in SCENARIOS else DEFAULT_SCENARIO
    return get_scenario(name)


@dataclass(frozen=True)
class SimulationResult:
    """What `simulate_scenario` produces.

    Attributes
    ----------
    scenario : Scenario
    track : trackmodel.Track
    seed : int
    truth : Truth
    imu_ideal : Imu
        Error-free IMU.
    imu_measured : Imu
        IMU with the scenario's errors.
    rng_streams : tuple of numpy.random.SeedSequence
        The spawned streams (see `RNG_STREAMS`), for the sensors simulated later.
    """

    scenario: Scenario
    track: Any
    seed: int
    truth: Truth
    imu_ideal: Imu
    imu_measured: Imu
    rng_streams: tuple = field(repr=False, default=())


def simulate_scenario(scenario: Scenario, *, track: Any = None, seed: int = 0,
                      progress: Callable[[int, int], None] | None = None) -> SimulationResult:
    """Simulate a scenario's truth and IMU on a track.

    Parameters
    ----------
    scenario : Scenario
    track : trackmodel.Track, str or os.PathLike, optional
        The track or its file; default the scenario's `default_track` in `TRACKS_DIR`.
    seed : int
        Seed of every random draw (>= 0).
    progress : callable, optional
        ``progress(done, total)`` over the 3 stages (truth, ideal IMU, errors).

    Returns
    -------
    SimulationResult

    Raises
    ------
    ConfigError
        No track given and no default, or a bad seed.
    trackmodel.TrackFileError, OSError
        For a bad track file.
    """
    # here, not at the top: the scenario table is read without CasADi (the CLI's parser)
    from railnav.simulation.joint_average import interval_mean_imu
    from railnav.simulation.truth import ideal_imu, simulate_truth_with_points
    from trackmodel.io import read_track

    if not (isinstance(seed, (int, np.integer)) and seed >= 0):
        raise ConfigError(f"seed must be an integer >= 0, got {seed!r}")
    if track is None:
        if scenario.default_track is None:
            raise ConfigError(f"scenario {scenario.name!r} has no default track; give one")
        track = TRACKS_DIR / scenario.default_track
    if not hasattr(track, "at"):
        track = read_track(track)
    tick = progress or (lambda done, total: None)
    streams = tuple(np.random.SeedSequence(int(seed)).spawn(len(RNG_STREAMS)))
    truth, point = simulate_truth_with_points(track, scenario.profile,
                                              duration_s=scenario.duration_s,
                                              rate_hz=scenario.imu_rate_hz,
                                              start_s=scenario.start_s)
    if truth.time_s[-1] < scenario.duration_s - 0.5 / scenario.imu_rate_hz:
        log.info("the trip reaches the track end at t = %.2f s (scenario: %.2f s)",
                 truth.time_s[-1], scenario.duration_s)
    tick(1, 3)
    if scenario.car_body is None:
        imu_ideal = interval_mean_imu(track, scenario.profile, ideal_imu(track, truth,
                                                                         point=point),
                                      start_s=scenario.start_s, rate_hz=scenario.imu_rate_hz)
    else:
        from railnav.simulation.car_body_motion import car_body_trip
        truth, imu_ideal = car_body_trip(
            track, truth, scenario.car_body,
            np.random.default_rng(streams[RNG_STREAMS["car_body"]]))
    tick(2, 3)
    imu_measured = apply_imu_errors(imu_ideal, scenario.imu,
                                    np.random.default_rng(streams[RNG_STREAMS["imu"]]))
    tick(3, 3)
    return SimulationResult(scenario=scenario, track=track, seed=int(seed), truth=truth,
                            imu_ideal=imu_ideal, imu_measured=imu_measured, rng_streams=streams)
