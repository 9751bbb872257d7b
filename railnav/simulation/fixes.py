"""Simulated GNSS position fixes: the truth plus errors of a chosen quality mix.

`simulate_fixes` samples the truth at the fix rate and draws, per fix, a position error
``N(0, diag(σ_h², σ_h², σ_v²))`` in ENU and a horizontal velocity error ``N(0, σ_speed² I)``
with the σ of the fix's class (`gnss_obs.fixes.quality.DEFAULT_FIX_SIGMAS` or a given
table), white from fix to fix: the fix model's assumption (`railnav.filters.fix_rows`), so
that a filter's NEES can be checked against it. The class changes every `FixSimConfig.
segment_s` seconds, drawn from the mix (receivers keep a solution type for a while). The
result is a fix table as the readers give it (every σ from the "file"), to be written with
`gnss_obs.fixes.writers` (``railnav simulate --fixes-format csv|nmea``). Fixes inside total
outages are not made (the receiver has no satellite).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gnss_obs.fixes.quality import DEFAULT_FIX_SIGMAS, FixSigmas
from gnss_obs.fixes.table import FIX_QUALITIES, FixLog, fix_frame
from gnss_obs.gpstime import gps_time_s_to_utc_iso
from gnss_obs.sim_events import in_outages
from railnav.errors import ConfigError
from railnav.simulation.scenarios import RNG_STREAMS
from trackmodel.earth import WGS84, C_n_e, ecef_to_geodetic

__all__ = ["FixSimConfig", "simulate_fixes", "trip_fixes", "parse_quality_mix",
           "DEFAULT_QUALITY_MIX", "FIX_FORMATS_WRITTEN"]

#: The default mix of fix classes (fractions of the segments).
DEFAULT_QUALITY_MIX = (("rtk_fixed", 0.4), ("dgps", 0.2), ("single", 0.4))
#: Formats ``railnav simulate --fixes-format`` writes.
FIX_FORMATS_WRITTEN = ("csv", "nmea")


def parse_quality_mix(text: str) -> tuple[tuple[str, float], ...]:
    """``rtk_fixed=0.5,single=0.5`` -> ``(("rtk_fixed", 0.5), ("single", 0.5))``.

    Raises
    ------
    ConfigError
        Bad syntax, an unknown class or weights that are not >= 0 with a positive sum.
    """
    mix = []
    for part in text.split(","):
        name, sep, weight = part.partition("=")
        try:
            value = float(weight)
        except ValueError:
            value = math.nan
        if not sep or name.strip() not in FIX_QUALITIES or not value >= 0:
            raise ConfigError(f"{text!r} is not CLASS=WEIGHT,... with CLASS one of "
                              f"{', '.join(FIX_QUALITIES)} and WEIGHT >= 0")
        mix.append((name.strip(), value))
    return FixSimConfig(quality_mix=tuple(mix)).quality_mix


@dataclass(frozen=True)
class FixSimConfig:
    """How fixes are simulated.

    Parameters
    ----------
    rate_hz : float
        Fix rate, Hz (must divide the truth's sample rate).
    quality_mix : tuple of (class, weight)
        Classes and their share of the segments (weights normalised).
    segment_s : float
        The class is drawn anew every this many seconds.
    sigmas : dict of str to FixSigmas
        The σ of each class (the errors drawn and the σ written).
    """

    rate_hz: float = 1.0
    quality_mix: tuple[tuple[str, float], ...] = DEFAULT_QUALITY_MIX
    segment_s: float = 30.0
    sigmas: dict[str, FixSigmas] = field(default_factory=lambda: dict(DEFAULT_FIX_SIGMAS))

    def __post_init__(self) -> None:
        for name in ("rate_hz", "segment_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be finite and > 0, got {value!r}")
        weights = [w for _, w in self.quality_mix]
        if not self.quality_mix or min(weights) < 0 or sum(weights) <= 0 or any(
                q not in self.sigmas for q, _ in self.quality_mix):
            raise ConfigError(f"quality_mix needs known classes with weights >= 0 and a "
                              f"positive sum, got {self.quality_mix!r}")

    def to_dict(self) -> dict:
        """JSON-ready (``scenario.json``)."""
        return {"rate_hz": self.rate_hz, "quality_mix": [list(q) for q in self.quality_mix],
                "segment_s": self.segment_s,
                "sigmas": {k: [v.horizontal_m, v.vertical_m, v.speed_mps]
                           for k, v in self.sigmas.items()}}


def simulate_fixes(truth, *, start_gps_time_s: float, config: FixSimConfig = FixSimConfig(),
                   rng: np.random.Generator, outages=(), earth=None,
                   antenna=None) -> FixLog:
    """Fixes of a simulated trip (module docstring).

    Parameters
    ----------
    truth : railnav.simulation.truth.Truth
    start_gps_time_s : float
        GPS time of ``truth.time_s = 0``.
    config : FixSimConfig
    rng : numpy.random.Generator
    outages : sequence of gnss_obs.Outage or (start_s, duration_s)
    earth : trackmodel.Ellipsoid, optional
        The track's Earth model (default WGS-84).
    antenna : (r_e, v_e), optional
        The antenna's ECEF position and velocity at the truth's samples (a lever arm:
        `railnav.simulation.track_sensors.antenna_track`; default the truth's point).

    Returns
    -------
    gnss_obs.fixes.table.FixLog
        ``format`` ``simulated``, UTC time scale.

    Raises
    ------
    ConfigError
        A rate that does not divide the truth's.
    """
    earth = earth or WGS84
    dt = float(np.median(np.diff(truth.time_s)))
    step = int(round(1.0 / (config.rate_hz * dt)))
    if step < 1 or abs(step * config.rate_hz * dt - 1.0) > 1e-6:
        raise ConfigError(f"the fix rate ({config.rate_hz} Hz) must divide the truth's "
                          f"sample rate ({1.0 / dt:g} Hz)")
    k = np.arange(0, truth.time_s.size, step)
    k = k[~in_outages(truth.time_s[k], outages)]
    t = truth.time_s[k]
    quality = _qualities(t, config, rng)
    sig = np.array([[config.sigmas[q].horizontal_m, config.sigmas[q].vertical_m,
                     config.sigmas[q].speed_mps] for q in quality]).reshape(-1, 3)
    e_n = rng.standard_normal((t.size, 3)) * sig[:, [0, 0, 1]]
    C = C_n_e(truth.lat[k], truth.lon[k])
    r_e, v_n = truth.r_e, truth.v_n
    if antenna is not None:
        r_e, v_n = antenna[0], np.einsum("kji,kj->ki", C_n_e(truth.lat, truth.lon), antenna[1])
    lat, lon, h = ecef_to_geodetic(r_e[k] + np.einsum("kij,kj->ki", C, e_n), earth=earth)
    v_h = v_n[k, :2] + rng.standard_normal((t.size, 2)) * sig[:, 2:3]
    gps = start_gps_time_s + t
    columns = {"gps_time_s": gps,
               "timestamp": gps_time_s_to_utc_iso(gps, suffix="Z").astype(object),
               "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon), "h_m": h,
               "speed_mps": np.hypot(v_h[:, 0], v_h[:, 1]),
               "course_deg": np.degrees(np.arctan2(v_h[:, 0], v_h[:, 1])) % 360.0,
               "sigma_east_m": sig[:, 0], "sigma_north_m": sig[:, 0], "sigma_up_m": sig[:, 1],
               "sigma_speed_mps": sig[:, 2], "quality": quality.astype(object),
               "flag": quality.astype(object),
               "sigma_source": np.full(t.size, "file", dtype=object)}
    table, _ = fix_frame(columns, path="simulated fixes")
    return FixLog(table, "simulated", "", "UTC", utc_suffix="Z")


def trip_fixes(trip, config: FixSimConfig = FixSimConfig()) -> FixLog:
    """`simulate_fixes` of a simulated trip: its truth, start time, outages, Earth model
    and its own random stream (`railnav.simulation.scenarios.RNG_STREAMS` ``fixes``).

    Parameters
    ----------
    trip : railnav.simulation.trip.SimulatedTrip
    config : FixSimConfig
    """
    from railnav.simulation.track_sensors import antenna_track
    rng = np.random.default_rng(trip.simulation.rng_streams[RNG_STREAMS["fixes"]])
    arm = getattr(trip.scenario, "antenna_m", (0.0, 0.0, 0.0))
    antenna = antenna_track(trip.track, trip.truth, arm) if any(arm) else None
    return simulate_fixes(trip.truth, start_gps_time_s=trip.scenario.start_gps_time_s,
                          config=config, rng=rng, outages=trip.scenario.outages,
                          earth=trip.track.earth, antenna=antenna)


def _qualities(t: np.ndarray, config: FixSimConfig, rng: np.random.Generator) -> np.ndarray:
    """The class of each fix: one draw from the mix per segment."""
    names = np.array([q for q, _ in config.quality_mix])
    weights = np.array([w for _, w in config.quality_mix], dtype=float)
    segment = np.floor(t / config.segment_s).astype(int) if t.size else np.zeros(0, int)
    n_segments = int(segment.max()) + 1 if t.size else 0
    draws = rng.choice(names.size, size=n_segments, p=weights / weights.sum())
    return names[draws[segment]] if t.size else np.zeros(0, dtype=object)

