r"""The vehicle's frame on the track, and the lever arms of its sensors in it.

**Track frame** at a point (`track_axes_n`, ENU; `track_axes_many_n` at many): ``along``
the unit tangent ``u`` (+s), ``along_h`` its horizontal direction, ``cross`` horizontal and
right of +s, ``left = −cross``, ``up`` the up-normal ``[−sinϑ sinA, −sinϑ cosA, cosϑ]`` (ϑ
elevation, A azimuth).
The track has no cant, so the vehicle's forward-left-up frame is this one.

**Lever arms** (`LeverArms`): where the sensors are relative to the vehicle's *reference
point*, the point of the track centre-line whose distance is the state ``s``, as
(forward, left, up) in metres: forward along +s (a vehicle that runs towards decreasing
``s`` with its antenna ahead has a negative forward offset), left of it, up from the
rail. The GNSS antenna at ``F, L, U`` is at::

    r_a(s) = r_e(s) + o_e(s),    o_e(s) = C_n_e(s) (F u + L left + U up)(s)

`antenna_track_part` shifts the track part of the GNSS and fix rows
(`railnav.filters.gnss_rows.track_rows`: ``r_ref, t_ref, k_ref`` of the expansion about
``s_ref``) by ``o_e`` and its first two derivatives along the track (central differences
over ±`OFFSET_STEP_M`: the offset's third derivative, ~``L κ³``, is below 1e-9 1/m² for a
2-m arm on a 150-m curve), so that every row of the antenna (pseudorange, range rate ``v
(t_e + o_e')``, fixes) keeps its model and its Jacobians through the track. The balise
reader is ``balise_reader_forward_m`` ahead of the reference point (its passage is of
``s + F_b``: `railnav.filters.balise_rows`). The IMU's offset ``imu_m`` is compensated in
its specific force (`strapdown.lever_arm`), so that the inertial filter mechanizes the
reference point.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError
from trackmodel.earth import C_n_e

__all__ = ["track_axes_n", "track_axes_many_n", "LeverArms", "antenna_offset_e",
           "antenna_track_part", "OFFSET_STEP_M", "parse_lever_arm"]

Array = npt.NDArray[np.float64]

#: Step of the central differences of the antenna offset along the track, m.
OFFSET_STEP_M = 0.5


def track_axes_n(point) -> dict[str, Array]:
    """Unit vectors of the track frame at a scalar track point, ENU (module docstring).

    Returns
    -------
    dict of str to ndarray (3,)
        ``along``, ``along_h``, ``cross``, ``left`` and ``up``.
    """
    A, E = float(point.azimuth), float(point.elevation)
    sin_a, cos_a, sin_e = np.sin(A), np.cos(A), np.sin(E)      # each evaluated once
    cross = np.array([cos_a, -sin_a, 0.0])
    return {"along": np.asarray(point.u_n, dtype=float),
            "along_h": np.array([sin_a, cos_a, 0.0]), "cross": cross, "left": -cross,
            "up": np.array([-sin_e * sin_a, -sin_e * cos_a, np.cos(E)])}


def track_axes_many_n(azimuth_rad, elevation_rad=None) -> dict[str, Array]:
    """`track_axes_n`'s horizontal axes, and ``up`` when the elevations are given, at many
    track points, ENU (module docstring).

    Parameters
    ----------
    azimuth_rad, elevation_rad : array_like, shape (N,)
        The points' azimuth and elevation, rad.

    Returns
    -------
    dict of str to ndarray (N, 3)
        ``along_h``, ``cross`` (right of +s), and ``up`` with `elevation_rad`.
    """
    A = np.asarray(azimuth_rad, dtype=float)
    out = {"along_h": np.column_stack([np.sin(A), np.cos(A), np.zeros_like(A)]),
           "cross": np.column_stack([np.cos(A), -np.sin(A), np.zeros_like(A)])}
    if elevation_rad is not None:
        E = np.asarray(elevation_rad, dtype=float)
        out["up"] = np.column_stack([-np.sin(E) * np.sin(A), -np.sin(E) * np.cos(A),
                                     np.cos(E)])
    return out


@dataclass(frozen=True)
class LeverArms:
    """Sensor offsets from the reference point (module docstring), m.

    Parameters
    ----------
    antenna_m : (float, float, float)
        GNSS antenna: forward, left, up.
    imu_m : (float, float, float)
        IMU: forward, left, up.
    balise_reader_forward_m : float
        Balise reader: forward.
    """

    antenna_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    imu_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    balise_reader_forward_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("antenna_m", "imu_m"):
            value = tuple(getattr(self, name))
            if len(value) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v)
                                          and abs(v) <= 100.0 for v in value):
                raise ConfigError(f"{name} must be 3 finite offsets within ±100 m, got "
                                  f"{getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        b = self.balise_reader_forward_m
        if not (isinstance(b, (int, float)) and math.isfinite(b) and abs(b) <= 100.0):
            raise ConfigError(f"balise_reader_forward_m must be finite within ±100 m, got {b!r}")

    @property
    def has_antenna(self) -> bool:
        """The antenna is off the reference point."""
        return any(self.antenna_m)


def parse_lever_arm(text: str) -> tuple[float, float, float]:
    """``"F,L,U"`` -> three floats (m).

    Raises
    ------
    ConfigError
        Not three comma-separated numbers.
    """
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{text!r} is not F,L,U: three offsets in metres (forward, left, "
                          "up)")
    return values  # type: ignore[return-value]


def antenna_offset_e(track, s: Array, arm: tuple[float, float, float]) -> Array:
    """``o_e(s)``: the offset (m, ECEF) of a point at ``arm`` = (forward, left, up) from
    the track points at distances `s` (N,), shape (N, 3)."""
    point = track.at(np.clip(np.atleast_1d(np.asarray(s, dtype=float)), 0.0, track.length_m))
    A, E = point.azimuth, point.elevation
    left = np.column_stack([-np.cos(A), np.sin(A), np.zeros_like(A)])
    up = np.column_stack([-np.sin(E) * np.sin(A), -np.sin(E) * np.cos(A), np.cos(E)])
    o_n = arm[0] * point.u_n + arm[1] * left + arm[2] * up
    return np.einsum("kij,kj->ki", C_n_e(point.lat, point.lon), o_n)


def antenna_track_part(track, part: Array, arm: tuple[float, float, float]) -> Array:
    """The track part of a row (`railnav.filters.gnss_rows.track_rows`, 13 values at
    ``s_ref``) for a point at `arm` from the reference point (module docstring)."""
    s_ref = float(part[0])
    h = OFFSET_STEP_M
    lo, hi = max(s_ref - h, 0.0), min(s_ref + h, track.length_m)
    o_lo, o_0, o_hi = antenna_offset_e(track, np.array([lo, s_ref, hi]), arm)
    d1 = (o_hi - o_lo) / (hi - lo)
    d2 = 2.0 * ((o_hi - o_0) / (hi - s_ref) - (o_0 - o_lo) / (s_ref - lo)) / (hi - lo) \
        if lo < s_ref < hi else np.zeros(3)
    out = np.array(part, dtype=float, copy=True)
    out[1:4] += o_0
    out[4:7] += d1
    out[7:10] += d2
    return out
