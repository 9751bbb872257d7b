"""Simulated IMU logs as a real logger writes them: jittered sample instants and dropouts.

`simulate_imu_log` samples the ideal IMU (`railnav.simulation.truth.ideal_imu`) of a trip at
jittered instants ``t_k = k/rate + j_k``, ``j_k ~ U(−jitter, +jitter)`` (the first and last
sample unjittered), evaluating the exact trajectory there (`truth_at`: the values belong to
the instants written, as a real sensor's do), removes `ImuLogSimConfig.dropouts` runs of
`dropout_samples` consecutive samples at random places (never the first or last two), and
adds the scenario's IMU errors (`strapdown.imu_errors.apply_imu_errors`, per-sample white
noise at the record's mean interval). The result is written as ``imu.csv`` by ``railnav simulate
--imu-jitter-s S --imu-dropouts N`` and read back by `strapdown.imu_log.read_imu_log`, so
tests and notebooks exercise the reader of real logs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from railnav.errors import ConfigError
from railnav.simulation.scenarios import RNG_STREAMS
from strapdown.imu import Imu
from strapdown.imu_errors import apply_imu_errors

__all__ = ["ImuLogSimConfig", "simulate_imu_log"]


@dataclass(frozen=True)
class ImuLogSimConfig:
    """How a simulated IMU log departs from a uniform record.

    Parameters
    ----------
    jitter_s : float
        Half-width of the uniform jitter of the sample instants, s (< a quarter interval).
    dropouts : int
        Number of dropouts (runs of missing samples), >= 0.
    dropout_samples : int
        Samples missing in each dropout, >= 1.
    """

    jitter_s: float = 2e-4
    dropouts: int = 0
    dropout_samples: int = 5

    def __post_init__(self) -> None:
        if not (isinstance(self.jitter_s, (int, float)) and math.isfinite(self.jitter_s)
                and self.jitter_s >= 0):
            raise ConfigError(f"jitter_s must be a finite number >= 0, got {self.jitter_s!r}")
        for name, low in (("dropouts", 0), ("dropout_samples", 1)):
            value = getattr(self, name)
            if not (isinstance(value, (int, np.integer)) and value >= low):
                raise ConfigError(f"{name} must be an integer >= {low}, got {value!r}")

    def to_dict(self) -> dict:
        """The ``scenario.json`` entry."""
        return {"jitter_s": self.jitter_s, "dropouts": self.dropouts,
                "dropout_samples": self.dropout_samples}


def simulate_imu_log(trip, config: ImuLogSimConfig = ImuLogSimConfig(), *,
                     errors=None) -> Imu:
    """The measured IMU of `trip` as a jittered log with dropouts (module docstring).

    Parameters
    ----------
    trip : railnav.simulation.trip.SimulatedTrip
    config : ImuLogSimConfig
    errors : str or strapdown.ImuErrors, optional
        The errors added (default the scenario's grade; ``"perfect"``: none).

    Raises
    ------
    ConfigError
        A jitter of a quarter interval or more, or more dropped samples than the trip has.
    """
    from railnav.simulation.truth import ideal_imu, truth_at
    sim = trip.simulation
    n = sim.truth.time_s.size
    interval = 1.0 / trip.scenario.imu_rate_hz
    if config.jitter_s >= interval / 4:
        raise ConfigError(f"jitter_s must be below a quarter interval ({interval / 4:g} s)")
    lost = config.dropouts * config.dropout_samples
    if lost > n // 2:
        raise ConfigError(f"{lost} dropped samples of a trip of {n}")
    rng = np.random.default_rng(sim.rng_streams[RNG_STREAMS["imu_log"]])
    t = sim.truth.time_s.copy()
    t[1:-1] += rng.uniform(-config.jitter_s, config.jitter_s, n - 2)
    keep = np.ones(n, dtype=bool)
    for _ in range(config.dropouts):
        start = int(rng.integers(2, n - 2 - config.dropout_samples))
        keep[start:start + config.dropout_samples] = False
    truth, _ = truth_at(sim.track, trip.scenario.profile, t[keep],
                        start_s=trip.scenario.start_s)
    ideal = ideal_imu(sim.track, truth)
    grade = trip.scenario.imu if errors is None else errors
    return apply_imu_errors(ideal, grade, rng)
