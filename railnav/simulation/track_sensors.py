"""Simulated railway sensors: an odometer with scale error, quantization, slips and slides,
and balise passages.

**Odometer** (`simulate_odometer`). The wheel turns at ``w(t) = (1 + k)(1 + e(t)) |v(t)|``:
``k`` the scale error (wheel wear; drawn ``N(0, scale_sigma²)`` per trip unless given),
``e(t)`` the slip/slide excess of the episodes (`SlipEpisode`: a trapezoid with
`SLIP_RAMP_S` ramps; ``e > 0`` a wheel spinning in traction, ``e < 0`` one sliding in
braking, ``e = −1`` locked). A ``speed`` sensor reads ``w(t_k) + N(0, σ²)`` (0 when the
wheel stands, clipped at 0, quantized to `OdometerSimConfig.resolution_mps` if set); a
``pulses`` sensor reads ``floor(∫w dt / L)`` (the trapezoid integral of ``w`` on the truth's
samples; ``L`` the pulse length), so its quantization is the real one. Readings at
`OdometerSimConfig.rate_hz` from the trip start.

**Balises** (`simulate_balises`): balises every `BaliseSimConfig.spacing_m` along the track
(or at given distances); each one the vehicle passes gives a row at the time its ``s``
crosses the balise, with the balise's surveyed distance off by ``N(0, σ²)`` and that σ.

**Barometer** (`simulate_baro_readings`): the true height at `BaroSimConfig.rate_hz` from the
trip start, with the errors of `railnav.evaluation.baro.simulate_baro` (a constant bias, a
random walk of the bias and white noise).

**Antenna** (`antenna_track`): the receiver's position and velocity at the scenario's
antenna lever arm (`railnav.filters.track_frame`), for the GNSS and fix simulations.

Each sensor has its own random stream (`railnav.simulation.scenarios.RNG_STREAMS`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError
from railnav.evaluation.baro import BaroConfig, simulate_baro
from railnav.filters.track_frame import OFFSET_STEP_M, antenna_offset_e
from railnav.simulation.scenarios import RNG_STREAMS

__all__ = ["SlipEpisode", "OdometerSimConfig", "simulate_odometer", "BaliseSimConfig",
           "simulate_balises", "BaroSimConfig", "simulate_baro_readings", "antenna_track",
           "SLIP_RAMP_S", "slip_excess",
           "sensor_models_from_simulation", "PULSE_READING_SIGMA_MPS"]

Array = npt.NDArray[np.float64]

#: Rise and fall time of a slip episode's excess, s.
SLIP_RAMP_S = 0.5
#: The noise a filter assumes for a simulated pulse count beyond its quantization (none
#: is simulated; the model needs a positive σ), m/s.
PULSE_READING_SIGMA_MPS = 0.005


@dataclass(frozen=True)
class SlipEpisode:
    """The wheel's excess over the vehicle for a while: ``start_s``, ``duration_s`` (s from
    the trip start) and ``excess`` (> −1 ... ; +0.2: 20 % fast, −1: locked)."""

    start_s: float
    duration_s: float
    excess: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.start_s) and self.start_s >= 0 and
                math.isfinite(self.duration_s) and self.duration_s > 0 and
                math.isfinite(self.excess) and -1.0 <= self.excess <= 10.0):
            raise ConfigError(f"a slip needs start >= 0, duration > 0 and -1 <= excess <= 10,"
                              f" got {self.start_s}, {self.duration_s}, {self.excess}")


def slip_excess(t: Array, episodes) -> Array:
    """``e(t)`` of the episodes (module docstring)."""
    e = np.zeros_like(np.asarray(t, dtype=float))
    for ep in episodes:
        rise = np.clip((t - ep.start_s) / SLIP_RAMP_S, 0.0, 1.0)
        fall = np.clip((ep.start_s + ep.duration_s - t) / SLIP_RAMP_S, 0.0, 1.0)
        e += ep.excess * np.minimum(rise, fall)
    return e


@dataclass(frozen=True)
class OdometerSimConfig:
    """How the odometer is simulated (module docstring).

    Parameters
    ----------
    rate_hz : float
    kind : str
        ``speed`` or ``pulses``.
    scale_error : float or None
        The wheel's ``k``; None: drawn ``N(0, scale_sigma²)``.
    scale_sigma : float
    sigma_mps : float
        White noise of a speed reading, m/s.
    resolution_mps : float
        Quantization of a speed reading, m/s (0: none).
    wheel_circumference_m, pulses_per_rev : float
        The pulse generator (``pulses``).
    slips : tuple of SlipEpisode
    """

    rate_hz: float = 10.0
    kind: str = "speed"
    scale_error: float | None = None
    scale_sigma: float = 0.02
    sigma_mps: float = 0.05
    resolution_mps: float = 0.0
    wheel_circumference_m: float = 2.89
    pulses_per_rev: float = 100.0
    slips: tuple[SlipEpisode, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in ("speed", "pulses"):
            raise ConfigError(f"odometer kind must be speed or pulses, got {self.kind!r}")
        for name in ("rate_hz", "scale_sigma", "sigma_mps", "wheel_circumference_m",
                     "pulses_per_rev"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.resolution_mps) and self.resolution_mps >= 0):
            raise ConfigError(f"resolution_mps must be >= 0, got {self.resolution_mps!r}")

    def to_dict(self, scale_error: float) -> dict:
        """The ``scenario.json`` entry, with the scale error drawn."""
        return {"rate_hz": self.rate_hz, "kind": self.kind, "scale_error": scale_error,
                "scale_sigma": self.scale_sigma, "sigma_mps": self.sigma_mps,
                "resolution_mps": self.resolution_mps,
                "wheel_circumference_m": self.wheel_circumference_m,
                "pulses_per_rev": self.pulses_per_rev,
                "slips": [[s.start_s, s.duration_s, s.excess] for s in self.slips]}


def simulate_odometer(trip, config: OdometerSimConfig = OdometerSimConfig()) -> dict:
    """The odometer readings of a trip (module docstring).

    Returns
    -------
    dict
        ``time_s`` (s from the trip start) and ``speed_mps`` or ``pulses``, and
        ``scale_error`` (the ``k`` used).
    """
    rng = np.random.default_rng(trip.simulation.rng_streams[RNG_STREAMS["odometer"]])
    k = config.scale_error if config.scale_error is not None else \
        float(config.scale_sigma * rng.standard_normal())
    truth = trip.truth
    wheel = (1.0 + k) * (1.0 + slip_excess(truth.time_s, config.slips)) * np.abs(truth.v)
    t = np.arange(0.0, truth.time_s[-1] + 1e-9, 1.0 / config.rate_hz)
    if config.kind == "pulses":
        turned = np.concatenate([[0.0], np.cumsum(0.5 * (wheel[1:] + wheel[:-1])
                                                  * np.diff(truth.time_s))])
        pulse_m = config.wheel_circumference_m / config.pulses_per_rev
        return {"time_s": t, "pulses": np.floor(np.interp(t, truth.time_s, turned) / pulse_m),
                "scale_error": k}
    w = np.interp(t, truth.time_s, wheel)
    reading = np.where(w > 1e-3, w + config.sigma_mps * rng.standard_normal(t.size), 0.0)
    if config.resolution_mps > 0:
        reading = config.resolution_mps * np.round(reading / config.resolution_mps)
    return {"time_s": t, "speed_mps": np.maximum(reading, 0.0), "scale_error": k}


@dataclass(frozen=True)
class BaliseSimConfig:
    """Where the balises are and how well their passages are known (module docstring).

    Parameters
    ----------
    spacing_m : float
        Distance between balises along the track, m.
    first_m : float
        Track distance of the first, m.
    positions_m : tuple of float
        Explicit distances (replace the spacing).
    sigma_m : float
        1σ of a passage's distance, m.
    """

    spacing_m: float = 1000.0
    first_m: float = 500.0
    positions_m: tuple[float, ...] = ()
    sigma_m: float = 0.5

    def __post_init__(self) -> None:
        for name in ("spacing_m", "sigma_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.first_m) and self.first_m >= 0):
            raise ConfigError(f"first_m must be >= 0, got {self.first_m!r}")

    def to_dict(self) -> dict:
        """The ``scenario.json`` entry."""
        return {"spacing_m": self.spacing_m, "first_m": self.first_m,
                "positions_m": list(self.positions_m), "sigma_m": self.sigma_m}


def simulate_balises(trip, config: BaliseSimConfig = BaliseSimConfig()) -> dict:
    """The balise passages of a trip (module docstring): ``time_s``, ``s_m``, ``sigma_m``,
    ``id`` (arrays)."""
    rng = np.random.default_rng(trip.simulation.rng_streams[RNG_STREAMS["balises"]])
    truth = trip.truth
    length = trip.track.length_m
    where = np.asarray(config.positions_m, dtype=float) if config.positions_m else \
        np.arange(config.first_m, length, config.spacing_m)
    s = np.maximum.accumulate(truth.s)          # forward runs (the profiles never reverse)
    passed = where[(where > s[0]) & (where <= s[-1])]
    t = np.interp(passed, s, truth.time_s)
    error = config.sigma_m * rng.standard_normal(passed.size)
    return {"time_s": t, "s_m": passed + error, "sigma_m": np.full(passed.size, config.sigma_m),
            "id": np.array([f"b{int(round(p))}" for p in passed], dtype=object)}


@dataclass(frozen=True)
class BaroSimConfig:
    """A simulated barometric altimeter (module docstring).

    Parameters
    ----------
    rate_hz : float
        Readings per second, from the trip start.
    bias_m : float
        Bias at the first reading, m (default 7: the 2021 paper's ΔH).
    noise : railnav.evaluation.baro.BaroConfig
        Its ``sigma_m`` (white noise, m) and ``bias_walk_mps`` (m/√s).
    """

    rate_hz: float = 1.0
    bias_m: float = 7.0
    noise: BaroConfig = BaroConfig()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigError(f"rate_hz must be finite and > 0, got {self.rate_hz!r}")
        if not math.isfinite(self.bias_m):
            raise ConfigError(f"bias_m must be finite, got {self.bias_m!r}")

    def to_dict(self) -> dict:
        """The ``scenario.json`` entry."""
        return {"rate_hz": self.rate_hz, "bias_m": self.bias_m,
                "sigma_m": self.noise.sigma_m, "bias_walk_mps": self.noise.bias_walk_mps}


def simulate_baro_readings(trip, config: BaroSimConfig = BaroSimConfig()) -> dict:
    """The baro readings of a trip: ``time_s`` (s from the trip start) and ``baro_h_m``
    (m), the true height interpolated at the reading times plus the errors of
    `railnav.evaluation.baro.simulate_baro`, on the trip's own ``baro`` random stream."""
    rng = np.random.default_rng(trip.simulation.rng_streams[RNG_STREAMS["baro"]])
    truth = trip.truth
    t = np.arange(0.0, truth.time_s[-1] + 1e-9, 1.0 / config.rate_hz)
    h = np.interp(t, truth.time_s, truth.h)
    return {"time_s": t, "baro_h_m": simulate_baro(t, h, bias_m=config.bias_m,
                                                   config=config.noise, rng=rng)}


def antenna_track(track, truth, antenna_m) -> tuple[Array, Array]:
    """ECEF position and velocity (m, m/s; (N, 3)) of the antenna at ``antenna_m`` (forward,
    left, up) from the truth's reference point: ``r_e + o_e(s)``, ``v_e + v o_e'(s)``."""
    if not any(antenna_m):
        return truth.r_e, truth.v_e
    h = OFFSET_STEP_M
    o = antenna_offset_e(track, truth.s, antenna_m)
    d_o = (antenna_offset_e(track, truth.s + h, antenna_m)
           - antenna_offset_e(track, truth.s - h, antenna_m)) / (2 * h)
    return truth.r_e + o, truth.v_e + truth.v[:, None] * d_o


def sensor_models_from_simulation(meta: dict) -> dict:
    """`NavigatorConfig` fields that assume what ``scenario.json`` says was simulated: the
    odometer's noise and scale prior, the balises' σ, the antenna's lever arm (only those
    the file names).

    Raises
    ------
    ConfigError
        A malformed entry.
    """
    from railnav.filters.balise_epochs import BaliseModelConfig
    from railnav.filters.odometer_epochs import OdometerConfig
    from railnav.filters.track_frame import LeverArms
    out = {}
    try:
        odo = meta.get("odometer")
        if odo:
            sigma = float(odo["sigma_mps"]) if odo["kind"] == "speed" else \
                PULSE_READING_SIGMA_MPS
            out["odometer_model"] = OdometerConfig(sigma_speed_mps=sigma,
                                                   scale_sigma=float(odo["scale_sigma"]))
        if meta.get("balises"):
            out["balise_model"] = BaliseModelConfig(sigma_m=float(meta["balises"]["sigma_m"]))
        arm = meta.get("scenario", {}).get("antenna_m")
        if arm and any(arm):
            out["lever_arms"] = LeverArms(antenna_m=tuple(float(a) for a in arm))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ConfigError(f"scenario.json: a sensor entry is malformed ({exc})") from None
    return out
