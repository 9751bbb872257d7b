"""GNSS fixes for a filter: the trip's fixes, the fix model's settings, the epoch schedule.

* `FixEpochs`: a fix table (`gnss_obs.fixes`) cut to the trip and to the outside of the
  total outages, with times from the trip start, positions in radians, the ENU position
  covariance and the velocity in ENU (from the file's components, else from speed and
  course; NaN where unknown);
* `FixModelConfig`: what the fix rows (`railnav.filters.fix_rows`) assume beyond each
  fix's own σ: how far the track's centre-line may be from where the antenna is;
* `EpochSchedule`: the run's measurement epochs, GNSS epochs (RINEX), fix epochs and other
  streams (odometer, balises) merged on time; an epoch may have several. The filters' ``observations(index, ...)`` take the
  index of this schedule.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from gnss_obs.sim_events import in_outages
from railnav.errors import ConfigError

__all__ = ["FixEpochs", "FixModelConfig", "EpochSchedule", "EPOCH_MATCH_S"]

Array = npt.NDArray[np.float64]
Index = npt.NDArray[np.intp]

#: A GNSS epoch and a fix closer than this are one epoch, s (the navigator's sample
#: tolerance, `railnav.navigation.loop.EPOCH_TIME_TOL_S`).
EPOCH_MATCH_S = 1e-6


@dataclass(frozen=True)
class FixModelConfig:
    """What the fix rows assume beyond each fix's σ.

    Parameters
    ----------
    track_cross_sigma_m : float
        1σ of the horizontal distance between the antenna and the track's centre-line
        that neither the track nor the fix σ explains, m: the map's own error, the antenna
        off the centre-line, a fix's error beyond its σ. Added to the cross-track row.
        Default 1.5 m: the Belgian logs' carrier-fixed rows lie a median 1.0-2.1 m and at
        most 3.3 m from the network centre-line (`data/tracks/brussels/README.md`).
    track_vertical_sigma_m : float
        The same for the height (antenna height above the rail, fitted track heights), m.
    use_height : bool
        Use the fixes' ellipsoidal heights (an up row); off for tracks without heights.
    use_speed : bool
        Use the fixes' velocity or speed and course (a speed row).
    correlated_code_errors : bool
        GNSS-only filter: inflate the rows of code fixes (single-point, DGPS) like its
        pseudoranges (``NavigatorConfig.pseudorange_correlation_s`` / ``_m``,
        `railnav.filters.gnss_only.GnssOnlyFilter.inflation_at`): their errors are their
        pseudoranges', correlated from epoch to epoch. Off by default: the network
        navigator's stacked fix rows (`railnav.navigation.stacked_fixes`) do not have it
        yet and must equal the per-filter rows. On the urban drive's SPP fixes it takes the
        fix-based filter's epochs beyond 3σ_s from 315 to 9 of 952
        (``benchmarks/bench_real_pieces.py``, which turns it on), and with the slow code
        error's state (`railnav.filters.code_bias`, its position rows at ``s + σ_e b``) to 0.
    """

    track_cross_sigma_m: float = 1.5
    track_vertical_sigma_m: float = 2.0
    use_height: bool = True
    use_speed: bool = True
    correlated_code_errors: bool = False

    def __post_init__(self) -> None:
        for name in ("track_cross_sigma_m", "track_vertical_sigma_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be a finite number >= 0, got {value!r}")


@dataclass(frozen=True, eq=False)
class FixEpochs:
    """The usable fixes of a trip (arrays of N fixes, in time order).

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        s from the trip start.
    lat, lon : ndarray, shape (N,)
        rad.
    h_m : ndarray, shape (N,)
        Ellipsoidal height, m (NaN: none).
    cov_n_m2 : ndarray, shape (N, 3, 3)
        Position covariance in ENU, m².
    v_n_mps : ndarray, shape (N, 3)
        Velocity in ENU, m/s (all NaN: none; up NaN: horizontal only).
    sigma_speed_mps : ndarray, shape (N,)
    quality : ndarray of str, shape (N,)
        The fix class (`gnss_obs.fixes.table.FIX_QUALITIES`).
    """

    time_s: Array
    lat: Array
    lon: Array
    h_m: Array
    cov_n_m2: Array
    v_n_mps: Array
    sigma_speed_mps: Array
    quality: np.ndarray

    def __len__(self) -> int:
        return self.time_s.size

    @classmethod
    def from_table(cls, table, *, start_gps_time_s: float, end_s: float = math.inf,
                   outages=()) -> "FixEpochs":
        """The fixes of ``[0, end_s]`` (s from the trip start) outside the total outages.

        Parameters
        ----------
        table : pandas.DataFrame
            A fix table with every σ (`gnss_obs.fixes.read_fixes`' ``table``).
        start_gps_time_s : float
            GPS time of the trip start, s.
        end_s : float
        outages : sequence of gnss_obs.Outage or (start_s, duration_s)
        """
        t = table["gps_time_s"].to_numpy(dtype=float) - start_gps_time_s
        keep = (t >= -EPOCH_MATCH_S) & (t <= end_s + EPOCH_MATCH_S) & ~in_outages(t, outages)
        tab = table[keep]

        def col(name: str) -> Array:
            return tab[name].to_numpy(dtype=float)

        n = int(keep.sum())
        cov = np.zeros((n, 3, 3))
        cov[:, 0, 0], cov[:, 1, 1] = col("sigma_east_m") ** 2, col("sigma_north_m") ** 2
        cov[:, 0, 1] = cov[:, 1, 0] = col("cov_en_m2")
        cov[:, 2, 2] = col("sigma_up_m") ** 2
        return cls(time_s=t[keep], lat=np.radians(col("lat_deg")), lon=np.radians(col("lon_deg")),
                   h_m=col("h_m"), cov_n_m2=cov, v_n_mps=_velocity_n(tab),
                   sigma_speed_mps=col("sigma_speed_mps"),
                   quality=tab["quality"].to_numpy(dtype=object))


def _velocity_n(tab) -> Array:
    """ENU velocity: the file's components where it has them, else horizontal from speed
    and course (course clockwise from north), else NaN."""
    v = tab[["v_east_mps", "v_north_mps", "v_up_mps"]].to_numpy(dtype=float).copy()
    speed = tab["speed_mps"].to_numpy(dtype=float)
    course = np.radians(tab["course_deg"].to_numpy(dtype=float))
    fill = ~np.isfinite(v[:, 0]) & np.isfinite(speed) & np.isfinite(course)
    v[fill, 0] = speed[fill] * np.sin(course[fill])
    v[fill, 1] = speed[fill] * np.cos(course[fill])
    v[fill, 2] = np.nan
    return v


@dataclass(frozen=True, eq=False)
class EpochSchedule:
    """A run's measurement epochs (module docstring).

    Attributes
    ----------
    time_s : ndarray, shape (E,)
        s from the trip start, increasing.
    gnss_index, fix_index : ndarray of int, shape (E,)
        The GNSS epoch (`railnav.filters.gnss_epochs.GnssEpochs`) and the fix
        (`FixEpochs`) of each epoch, -1 where it has none.
    extra : dict of str to ndarray of int, shape (E,)
        The same for other measurement streams by name (``odometer``, ``balises``:
        `railnav.filters.sensor_rows`).
    """

    time_s: Array
    gnss_index: Index
    fix_index: Index
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return self.time_s.size

    def split(self, index: int) -> tuple[int, int]:
        """The GNSS epoch and the fix of epoch `index` (-1: none)."""
        return int(self.gnss_index[index]), int(self.fix_index[index])

    def index(self, stream: str, index: int) -> int:
        """The row of stream `stream` at epoch `index` (-1: none, or no such stream)."""
        rows = self.extra.get(stream)
        return -1 if rows is None else int(rows[index])

    @classmethod
    def merge(cls, gnss_time_s: npt.ArrayLike, fix_time_s: npt.ArrayLike, *,
              tol_s: float = EPOCH_MATCH_S, extra: dict | None = None) -> "EpochSchedule":
        """GNSS epochs, fixes and other streams merged on time (within `tol_s` they share
        an epoch).

        Parameters
        ----------
        gnss_time_s, fix_time_s : array_like, shape (G,) and (F,)
            Increasing times, s.
        extra : dict of str to array_like, optional
            Increasing times of other streams, s.
        """
        streams = {"gnss": gnss_time_s, "fix": fix_time_s, **(extra or {})}
        times = {k: np.asarray(v, dtype=float).reshape(-1) for k, v in streams.items()}
        every = np.concatenate(list(times.values()))
        owner = np.concatenate([np.full(v.size, i) for i, v in enumerate(times.values())])
        row = np.concatenate([np.arange(v.size) for v in times.values()])
        order = np.argsort(every, kind="stable")
        sorted_t = every[order]
        new = np.concatenate([[True], np.diff(sorted_t) > tol_s]) if every.size else \
            np.zeros(0, dtype=bool)
        epoch_of = np.cumsum(new) - 1
        n = int(new.sum())
        index = {}
        for i, name in enumerate(times):
            mine = owner[order] == i
            index[name] = np.full(n, -1, dtype=np.intp)
            index[name][epoch_of[mine]] = row[order][mine]
        return cls(sorted_t[new], index.pop("gnss"), index.pop("fix"), index)
