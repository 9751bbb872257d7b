"""A simulated trip produced segment by segment, for trips too long to hold in memory.

`trip_segments` yields the trip of `railnav.simulation.trip.simulate_trip` in consecutive segments of
``segment_s`` seconds: the truth (`railnav.simulation.truth.iter_truth`), the measured IMU
(`ImuErrorStream`), and the GNSS observations of the segment's epochs, cut into
`railnav.filters.gnss_epochs.GnssEpochs` for the filter. The processes that run across segments
continue exactly: the IMU's constant errors are drawn once and its Gauss–Markov biases
carry their state; the receiver clock of each segment starts from the previous segment's
last epoch (simulated again as the first epoch of the call, then dropped). Outages are
the scenario's (seconds from the trip start).

Random streams are those of `railnav.simulation.scenarios.RNG_STREAMS`, each consumed in trip order.
The realisation therefore depends on ``segment_s`` (the IMU noise of each segment is
drawn after its biases' driving noise), not on anything else: a streamed trip is
reproducible, but it is not the same draw as `simulate_trip` of the same seed.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, fields, replace

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.rinex_nav import RinexNav
from gnss_obs.rinex_obs import RinexObs
from gnss_obs.simulate import simulate_gnss
from railnav.config import DEFAULT_SYSTEMS, NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.gnss_epochs import GnssEpochs
from railnav.simulation.joint_average import interval_mean_imu
from railnav.simulation.scenarios import RNG_STREAMS, Scenario
from railnav.simulation.trip import gnss_sim_config_for
from railnav.simulation.truth import Truth, ideal_imu, iter_truth_with_points
from strapdown.imu import Imu
from strapdown.imu_errors import (
    ImuErrors,
    TriadErrors,
    gauss_markov_recursion,
    imu_grade,
    rows_times,
)

__all__ = ["ImuErrorStream", "TripSegment", "trip_segments", "concat_truth", "epoch_step"]

Array = npt.NDArray[np.float64]

_PPM = 1e-6
_EMPTY_CLOCK = pd.DataFrame({"time_s": [], "clock_bias_m": [], "clock_drift_mps": []})


class ImuErrorStream:
    """`strapdown.imu_errors.apply_imu_errors` applied block by block.

    The model and its parameters are those of `strapdown.imu_errors`. The first block
    draws, per triad (accelerometers, then gyros), scale factors, misalignments, constant
    bias and the Gauss–Markov start, then that block's bias driving noise and white noise
    — the order of `apply_imu_errors`, so that one block covering a record gives its
    result. Later blocks draw only their driving and white noise, and the Gauss–Markov
    biases continue from the previous block's last value.

    Parameters
    ----------
    errors : str or ImuErrors
        Grade preset or parameters.
    rng : numpy.random.Generator
    dt : float
        Sample interval, s (the same for every block).
    """

    def __init__(self, errors: str | ImuErrors, rng: np.random.Generator, *, dt: float) -> None:
        self.errors = imu_grade(errors)
        self.rng, self.dt = rng, float(dt)
        self._triads: dict[str, dict] = {}

    def apply(self, imu: Imu) -> Imu:
        """The measured samples of the next block of true samples `imu` (N samples)."""
        if self.errors.is_perfect:
            return imu
        f_b = self._corrupt("accel", imu.f_b)
        omega = self._corrupt("gyro", imu.omega_ib_b)
        return replace(imu, f_b=f_b, omega_ib_b=omega)

    def _corrupt(self, sensor: str, true: Array) -> Array:
        p: TriadErrors = self.errors.triad(sensor)
        state = self._triads.get(sensor)
        if state is None:
            scale = p.scale_factor_ppm * _PPM * self.rng.standard_normal(3)
            mis = p.misalignment_rad * self.rng.standard_normal((3, 3))
            matrix = np.eye(3) + np.diag(scale) + (mis - np.diag(np.diag(mis)))
            bias = p.bias * self.rng.standard_normal(3)
            state = {"matrix": matrix, "bias": bias,
                     "gm": p.instability * self.rng.standard_normal(3)}
            self._triads[sensor] = state
        phi = math.exp(-self.dt / p.tau_s)
        gain = p.instability * math.sqrt(-math.expm1(-2.0 * self.dt / p.tau_s))
        drive = self.rng.standard_normal((len(true), 3))
        drift = gauss_markov_recursion(drive, gain=gain, phi=phi, start=state["gm"])
        state["gm"] = drift[-1].copy()
        noise = p.noise_density / math.sqrt(self.dt) * self.rng.standard_normal(true.shape)
        return rows_times(true, state["matrix"]) + state["bias"] + drift + noise


@dataclass(frozen=True, eq=False)
class TripSegment:
    """One segment of a streamed trip.

    Attributes
    ----------
    index : int
        0 for the first segment.
    truth : railnav.simulation.truth.Truth
        The segment's samples (times from the trip start).
    truth_window : railnav.simulation.truth.Truth
        The previous segment's last sample (if any) followed by `truth`: the times the
        filter can store while it works through this segment.
    imu : strapdown.Imu
        Measured IMU samples at ``truth.time_s``.
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
        The segment's GNSS epochs (None without GNSS).
    obs : gnss_obs.RinexObs or None
        The segment's simulated observations (those of `gnss`).
    clock : pandas.DataFrame
        Receiver clock truth ``time_s, clock_bias_m, clock_drift_mps`` from the previous
        segment's last epoch through this segment's epochs.
    """

    index: int
    truth: Truth
    truth_window: Truth
    imu: Imu
    gnss: GnssEpochs | None
    obs: RinexObs | None
    clock: pd.DataFrame

    def clock_truth(self, time_s: npt.ArrayLike,
                    following: "TripSegment | None" = None) -> tuple[Array, Array]:
        """True receiver clock bias (m) and drift (m/s) at times from the trip start,
        interpolated between epochs (through the `following` segment's first epochs for
        times after this segment's last epoch)."""
        t = np.asarray(time_s, dtype=float)
        table = self.clock if following is None else pd.concat(
            [self.clock, following.clock.iloc[1:2]], ignore_index=True)
        if len(table) == 0:
            return np.zeros_like(t), np.zeros_like(t)
        tc = table["time_s"].to_numpy()
        return (np.interp(t, tc, table["clock_bias_m"].to_numpy()),
                np.interp(t, tc, table["clock_drift_mps"].to_numpy()))


def concat_truth(a: Truth, b: Truth) -> Truth:
    """Samples of `a` followed by those of `b`."""
    return Truth(**{f.name: np.concatenate([getattr(a, f.name), getattr(b, f.name)])
                    for f in fields(Truth)})


def epoch_step(scenario: Scenario) -> int:
    """IMU samples per GNSS epoch.

    Raises
    ------
    ConfigError
        If the GNSS rate does not divide the IMU rate.
    """
    ratio = scenario.imu_rate_hz / scenario.gnss_rate_hz
    step = int(round(ratio))
    if step < 1 or abs(ratio - step) > 1e-9:
        raise ConfigError(f"the GNSS rate ({scenario.gnss_rate_hz} Hz) must divide the IMU "
                          f"rate ({scenario.imu_rate_hz} Hz)")
    return step


def trip_segments(scenario: Scenario, track, *, seed: int, config: NavigatorConfig,
                  nav: RinexNav | None, systems: str = DEFAULT_SYSTEMS,
                  segment_s: float = 300.0) -> Iterator[TripSegment]:
    """Simulate `scenario` on `track` segment by segment (module docstring).

    Parameters
    ----------
    scenario : Scenario
    track : trackmodel.Track
    seed : int
        Seed of every random draw (>= 0).
    config : NavigatorConfig
        The filter's GNSS settings (measurement model, elevation mask) for the epochs.
    nav : gnss_obs.RinexNav or None
        Constellation covering the trip (`gnss_obs.ephemeris_reissue` for long trips);
        None: no GNSS.
    systems : str
        GNSS systems simulated.
    segment_s : float
        Segment length, s (a whole number of GNSS epochs is not required).

    Yields
    ------
    TripSegment
    """
    if not (isinstance(seed, (int, np.integer)) and seed >= 0):
        raise ConfigError(f"seed must be an integer >= 0, got {seed!r}")
    if not (math.isfinite(segment_s) and segment_s > 0):
        raise ConfigError(f"segment_s must be finite and > 0, got {segment_s!r}")
    step = epoch_step(scenario)
    rate = scenario.imu_rate_hz
    streams = np.random.SeedSequence(int(seed)).spawn(len(RNG_STREAMS))
    imu_errors = ImuErrorStream(scenario.imu, np.random.default_rng(streams[RNG_STREAMS["imu"]]),
                                dt=1.0 / rate)
    gnss_rng = np.random.default_rng(streams[RNG_STREAMS["gnss"]])
    block = max(2, int(round(segment_s * rate)))
    previous: Truth | None = None
    head: dict | None = None
    blocks = iter_truth_with_points(track, scenario.profile, duration_s=scenario.duration_s,
                                    rate_hz=rate, start_s=scenario.start_s, block_size=block)
    for index, (truth, point) in enumerate(blocks):
        imu = imu_errors.apply(interval_mean_imu(track, scenario.profile,
                                                 ideal_imu(track, truth, point=point),
                                                 start_s=scenario.start_s, rate_hz=rate))
        gnss, obs, clock = None, None, _EMPTY_CLOCK
        if nav is not None:
            gnss, obs, clock, head = _segment_gnss(scenario, truth, step, nav, config,
                                                   systems, head, gnss_rng)
        window = truth if previous is None else concat_truth(previous.rows(slice(-1, None)), truth)
        yield TripSegment(index, truth, window, imu, gnss, obs, clock)
        previous = truth


def _segment_gnss(scenario: Scenario, truth: Truth, step: int, nav: RinexNav,
                  config: NavigatorConfig, systems: str, head: dict | None,
                  rng: np.random.Generator):
    """GNSS epochs, observations and clock truth of one segment (the clock from `head`
    on), and the head of the next segment: the last
    epoch's ``time_s, r_e, v_e, bias_m, drift_mps``, from which the next segment's clock
    continues (that epoch is simulated again first and its observations dropped)."""
    k = np.round(truth.time_s * scenario.imu_rate_hz).astype(np.int64)
    at = np.flatnonzero(k % step == 0)
    t, r_e, v_e = truth.time_s[at], truth.r_e[at], truth.v_e[at]
    bias0 = drift0 = 0.0
    if head is not None:
        t = np.r_[head["time_s"], t]
        r_e, v_e = np.vstack([head["r_e"], r_e]), np.vstack([head["v_e"], v_e])
        bias0, drift0 = head["bias_m"], head["drift_mps"]
    if t.size == 0:
        return None, None, _EMPTY_CLOCK, head
    sim_config = replace(gnss_sim_config_for(scenario, systems=systems),
                         clock_bias0_m=bias0, clock_drift0_mps=drift0)
    start = scenario.start_gps_time_s
    sim = simulate_gnss(start + t, r_e, v_e, nav, sim_config, rng=rng)
    table = sim.obs.table
    if head is not None:
        table = table[table["gps_time_s"] > start + t[0] + 0.5 / scenario.gnss_rate_hz]
    obs = RinexObs(sim.obs.header, table.reset_index(drop=True))
    gnss = GnssEpochs.from_files(obs, nav, config.measurement, start_gps_time_s=start,
                                 end_s=float(truth.time_s[-1]),
                                 elevation_mask_deg=config.elevation_mask_deg)
    bias, drift = sim.clock["clock_bias_m"].to_numpy(), sim.clock["clock_drift_mps"].to_numpy()
    clock = pd.DataFrame({"time_s": t, "clock_bias_m": bias, "clock_drift_mps": drift})
    new_head = {"time_s": float(t[-1]), "r_e": r_e[-1:], "v_e": v_e[-1:],
                "bias_m": float(bias[-1]), "drift_mps": float(drift[-1])}
    return gnss, obs, clock, new_head

