"""The configuration of a Monte Carlo study (`railnav.studies.study`).

`StudyConfig` holds the grid axes (tuples of values: every combination is run
``replicates`` times) and the run settings; each field is checked by `check_field`, which
`railnav.studies.file` also calls to locate a bad value in the TOML file it came from.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Callable

from gnss_obs.errors import GnssError
from gnss_obs.measurements import MeasurementConfig
from railnav.errors import ConfigError
from railnav.filters.protocol import FILTER_KINDS, FILTERS
from railnav.simulation.route_tracks import route_spec_text, split_route_spec
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from strapdown.imu_errors import IMU_GRADES

__all__ = ["StudyConfig", "check_field", "MODES", "DEFAULT_CHUNK_RUNS", "FIELD_CHECKS"]

#: How each run is simulated and filtered: in memory (`railnav.jobs.run.run_simulated`) or
#: streamed (`railnav.navigation.streaming.stream_simulated`).
MODES = ("memory", "streaming")
#: Runs per results part file: an interrupted study redoes at most this many runs per
#: worker batch.
DEFAULT_CHUNK_RUNS = 16

Outages = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class StudyConfig:
    """A study: grid axes (tuples of values, every combination run) and run settings.

    Parameters
    ----------
    name : str
    seed : int
        Master seed (>= 0).
    replicates : int
        Monte Carlo runs per grid cell (>= 1).
    scenario : str
        Base scenario name (`railnav.simulation.scenarios.SCENARIOS`).
    duration_s : float
        Trip duration, s.
    systems : str
        GNSS systems simulated and used.
    mode : {"memory", "streaming"}
    chunk_runs : int
        Runs per results part file (>= 1).
    common_random_numbers : bool
        Replicate ``r`` has the same seed in every grid cell (paired comparisons);
        otherwise each cell's seeds also depend on its parameters.
    segment_s : float
        Streaming mode: segment length, s.
    tracks : tuple of str
        Track files as written in the configuration, or network routes
        ``NETWORK:E1,E2,...`` (`railnav.simulation.route_tracks`).
    imu_grades : tuple of str
        IMU grade presets (`strapdown.imu_errors.IMU_GRADES`), simulated and assumed.
    speeds_mps : tuple of float
        Top speeds, m/s.
    filters : tuple of str
        `railnav.filters.protocol.FILTERS` (streaming: those that stream).
    sigma_pseudorange_m, sigma_range_rate_mps : tuple of float
        GNSS noise 1σ, m and m/s (simulated and assumed).
    outage_sets : tuple of tuple of (start_s, duration_s)
        Each run's GNSS outages, s from the trip start.
    base_dir : pathlib.Path
        Where relative track paths start (the configuration file's folder).
    """

    name: str
    seed: int
    replicates: int
    scenario: str
    duration_s: float
    systems: str
    mode: str
    chunk_runs: int
    common_random_numbers: bool
    segment_s: float
    tracks: tuple[str, ...]
    imu_grades: tuple[str, ...]
    speeds_mps: tuple[float, ...]
    filters: tuple[str, ...]
    sigma_pseudorange_m: tuple[float, ...]
    sigma_range_rate_mps: tuple[float, ...]
    outage_sets: tuple[Outages, ...]
    base_dir: Path = Path(".")

    def __post_init__(self) -> None:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        for name in FIELD_CHECKS:
            check_field(name, values)

    def track_path(self, track: str) -> Path:
        """The file of a track named in the configuration.

        Raises
        ------
        ConfigError
            If neither ``base_dir/track`` nor ``data/tracks/track`` exists.
        """
        return _track_file(track, Path(self.base_dir))

    def track_text(self, track: str) -> str:
        """The track-file text of a track named in the configuration: a file's content,
        or a network route's line (`railnav.simulation.route_tracks`)."""
        from trackmodel.textfile import read_text
        try:
            return read_text(self.track_path(track), error=ConfigError)
        except ConfigError:
            if split_route_spec(track) is None:
                raise
        return route_spec_text(track, Path(self.base_dir))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready settings (``study.json``)."""
        out = asdict(self)
        out["base_dir"] = str(self.base_dir)
        out["outage_sets"] = [[list(w) for w in s] for s in self.outage_sets]
        return out


def _integer(name: str, minimum: int) -> Callable:
    def check(value, values) -> None:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise ConfigError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return check


def _positive(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be a finite number > 0, got {value!r}")


def _axis(name: str, each: Callable | None = None) -> Callable:
    """A grid axis: a non-empty tuple of distinct values, each passing `each`."""
    def check(values: tuple, all_values: dict) -> None:
        if not values:
            raise ConfigError(f"{name} needs at least one value")
        if len(set(values)) != len(values):
            raise ConfigError(f"{name} has repeated values: {list(values)}")
        for value in values:
            if each is not None:
                each(value, all_values)
    return check


def _check_name(value, values) -> None:
    if not isinstance(value, str) or not value:
        raise ConfigError("name must be a non-empty string")


def _check_mode(value, values) -> None:
    if value not in MODES:
        raise ConfigError(f"mode must be one of {', '.join(MODES)}, got {value!r}")


def _check_systems(value, values) -> None:
    try:
        MeasurementConfig(systems=value)
    except GnssError as exc:
        raise ConfigError(str(exc)) from None


def _check_grade(value, values) -> None:
    if value not in IMU_GRADES:
        raise ConfigError(f"unknown IMU grade {value!r}; presets are {', '.join(IMU_GRADES)}")


def _check_filter(value, values) -> None:
    allowed = (tuple(k for k in FILTER_KINDS if FILTERS[k].streams)
               if values.get("mode") == "streaming" else FILTER_KINDS)
    if value not in allowed:
        raise ConfigError(f"filter must be one of {', '.join(allowed)} in "
                          f"{values.get('mode')} mode, got {value!r}")


def _check_outages(windows, values) -> None:
    for start, duration in windows:
        if not (math.isfinite(start) and start >= 0 and math.isfinite(duration)
                and duration > 0):
            raise ConfigError(f"outage ({start}, {duration}): need start_s >= 0 and "
                              "duration_s > 0")


def _check_track(value, values) -> None:
    base_dir = Path(values.get("base_dir", "."))
    try:
        _track_file(value, base_dir)
    except ConfigError:
        if split_route_spec(value) is None:
            raise
        route_spec_text(value, base_dir)


def _track_file(track: str, base_dir: Path) -> Path:
    for candidate in (base_dir / track, TRACKS_DIR / track):
        if candidate.is_file():
            return candidate
    raise ConfigError(f"track {track!r} not found (looked in {base_dir} and {TRACKS_DIR})")


def _check_bool(value, values) -> None:
    if not isinstance(value, bool):
        raise ConfigError(f"common_random_numbers must be true or false, got {value!r}")


def _positive_field(name: str) -> Callable:
    return lambda value, values: _positive(name, value)


#: Checks of each field (value, all field values), in the order they are run.
FIELD_CHECKS: dict[str, Callable] = {
    "name": _check_name, "seed": _integer("seed", 0), "replicates": _integer("replicates", 1),
    "scenario": lambda value, values: get_scenario(value),
    "duration_s": _positive_field("duration_s"), "systems": _check_systems,
    "mode": _check_mode, "chunk_runs": _integer("chunk_runs", 1),
    "common_random_numbers": _check_bool,
    "segment_s": _positive_field("segment_s"), "tracks": _axis("track", _check_track),
    "imu_grades": _axis("imu_grade", _check_grade),
    "speeds_mps": _axis("speed_mps", _positive_field("speed_mps")),
    "filters": _axis("filter", _check_filter),
    "sigma_pseudorange_m": _axis("sigma_pseudorange_m",
                                 _positive_field("sigma_pseudorange_m")),
    "sigma_range_rate_mps": _axis("sigma_range_rate_mps",
                                  _positive_field("sigma_range_rate_mps")),
    "outage_sets": _axis("outages", _check_outages),
}


def check_field(name: str, values: dict[str, Any]) -> None:
    """Check field `name` of `values` (all fields by name: some checks need others).

    Raises
    ------
    ConfigError
        Unlocated: the caller knows where the value came from.
    """
    FIELD_CHECKS[name](values[name], values)
