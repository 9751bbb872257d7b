"""Balise passages for a filter: the model's settings and the trip's passages.

* `BaliseModelConfig`: what the balise rows (`railnav.filters.balise_rows`) assume;
* `BaliseEpochs`: a balise file's passages (`railnav.sensors.balises`) within the run, times
  from the trip start, each balise's track distance (a coordinate projected on the track;
  one farther than `BaliseModelConfig.max_offset_m` is an error: a list for another line)
  and σ.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.defaults import DEFAULT_BALISE_SIGMA_M
from railnav.errors import ConfigError

__all__ = ["BaliseModelConfig", "BaliseEpochs", "BALISE_ROW_KIND", "BALISE_SV_PREFIX"]

Array = npt.NDArray[np.float64]

#: Kind of a balise row in ``innovations.csv``.
BALISE_ROW_KIND = "balise"
#: ``sv`` of a balise row: this prefix and the balise's id.
BALISE_SV_PREFIX = "balise:"


@dataclass(frozen=True)
class BaliseModelConfig:
    """What the balise rows assume.

    Parameters
    ----------
    sigma_m : float
        1σ of a passage without a σ of its own, m (> 0). Default 1 m: the ±1 m of a
        balise's surveyed position along the line (ETCS location accuracy) and the
        reader's detection timing.
    max_offset_m : float
        A balise given as a coordinate farther than this from the track is an error, m.
    """

    sigma_m: float = DEFAULT_BALISE_SIGMA_M
    max_offset_m: float = 20.0

    def __post_init__(self) -> None:
        for name in ("sigma_m", "max_offset_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a finite number > 0, got {value!r}")


@dataclass(frozen=True, eq=False)
class BaliseEpochs:
    """The passages of a run (arrays of N, in time order).

    Attributes
    ----------
    time_s : ndarray
        s from the trip start.
    s_m : ndarray
        Track distance of each balise, m.
    sigma_m : ndarray
    ids : ndarray of str
    """

    time_s: Array
    s_m: Array
    sigma_m: Array
    ids: np.ndarray

    def __len__(self) -> int:
        return self.time_s.size

    @classmethod
    def from_log(cls, log, track, *, start_gps_time_s: float, config: BaliseModelConfig,
                 span_s: tuple[float, float]) -> "BaliseEpochs":
        """The passages of `log` (`railnav.sensors.balises.BaliseLog`) within the run, their
        coordinates projected on `track`.

        Raises
        ------
        ConfigError
            No passage within the run; a balise farther than ``config.max_offset_m`` from
            the track or beyond its ends (its row).
        """
        t = log.relative_time_s(start_gps_time_s)
        keep = (t >= span_s[0]) & (t <= span_s[1])
        if not keep.any():
            raise ConfigError(f"balise times [{t[0]:.1f}, {t[-1]:.1f}] s miss the run "
                              f"[{span_s[0]:.1f}, {span_s[1]:.1f}] s (from the trip start)",
                              path=log.path)
        s = np.array(log.s_m, dtype=float, copy=True)
        coord = ~np.isfinite(s)
        if coord.any():
            lat, lon = np.radians(log.lat_deg[coord]), np.radians(log.lon_deg[coord])
            proj = track.project(lat, lon)
            off = np.hypot(np.asarray(proj.cross_track_m), np.asarray(proj.along_m))
            far = off > config.max_offset_m
            if far.any():
                row = int(np.flatnonzero(coord)[np.flatnonzero(far)[0]]) + 1
                raise ConfigError(f"balise {off[far][0]:.1f} m from the track (more than "
                                  f"{config.max_offset_m:g} m)", path=log.path, row=row,
                                  column="lat_deg")
            s[coord] = proj.s
        beyond = (s > track.length_m) & keep
        if beyond.any():
            raise ConfigError(f"balise at s = {s[beyond][0]:.1f} m is beyond the track "
                              f"({track.length_m:.1f} m)", path=log.path,
                              row=int(np.flatnonzero(beyond)[0]) + 1, column="s_m")
        sigma = np.where(np.isfinite(log.sigma_m), log.sigma_m, config.sigma_m)
        return cls(t[keep], s[keep], sigma[keep], log.ids[keep])
