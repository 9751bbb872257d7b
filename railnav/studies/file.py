"""The TOML file of a study: `load_study_config` -> `railnav.studies.config.StudyConfig`.

Three tables (example: ``data/studies/outages.toml``)::

    [study]                       # how the study runs
    name = "outages"
    seed = 2017                   # master seed (run seeds derive from it)
    replicates = 20               # Monte Carlo runs per grid cell
    scenario = "paper2017"        # base scenario (railnav.simulation.scenarios.SCENARIOS)
    duration_s = 400.0            # default: the scenario's
    systems = "G"                 # GNSS systems simulated and used
    mode = "memory"               # or "streaming" (railnav.navigation.streaming, for long trips)
    chunk_runs = 16               # runs per results part (resume granularity)
    common_random_numbers = true  # replicate r uses the same seed in every cell

    [grid]                        # each key a value or a list; absent: the scenario's
    track = ["paper2017.csv"]     # file in data/tracks/, a path relative to this file, or a
                                  # network route NETWORK:E1,E2,... (simulation.route_tracks)
    imu_grade = ["navigation", "tactical", "mems"]
    speed_mps = [20.0]            # top speed (the scenario's profile scaled)
    filter = ["constrained", "unconstrained"]
    sigma_pseudorange_m = [3.873]
    sigma_range_rate_mps = [0.707]
    outage_start_s = [200.0]      # one outage per run: start x duration
    outage_duration_s = [10.0, 30.0, 60.0]
    # outages = [[[100.0, 50.0], [500.0, 50.0]]]   # or explicit sets of windows

    [streaming]
    segment_s = 300.0

A problem in the file raises `railnav.errors.ConfigError` with the file, the line of the
key and the key (``outages.toml: line 12, grid.imu_grade: unknown IMU grade 'x'``).
"""
from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import Any, Callable

from railnav.config import DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.navigation.streaming import DEFAULT_SEGMENT_S
from railnav.simulation.scenarios import get_scenario
from railnav.studies.config import (
    DEFAULT_CHUNK_RUNS,
    FIELD_CHECKS,
    StudyConfig,
    check_field,
)
from trackmodel.textfile import read_text

try:                                    # Python >= 3.11
    import tomllib
except ModuleNotFoundError:             # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["load_study_config", "parse_study_config", "MAX_STUDY_RUNS"]

Outages = tuple[tuple[float, float], ...]

#: Most runs one study file may describe (a million one-minute runs: two CPU-years).
MAX_STUDY_RUNS = 1_000_000

#: The file key of each validated field.
_FIELD_KEYS = {"name": ("study", "name"), "seed": ("study", "seed"),
               "replicates": ("study", "replicates"), "scenario": ("study", "scenario"),
               "duration_s": ("study", "duration_s"), "systems": ("study", "systems"),
               "mode": ("study", "mode"), "chunk_runs": ("study", "chunk_runs"),
               "common_random_numbers": ("study", "common_random_numbers"),
               "segment_s": ("streaming", "segment_s"), "tracks": ("grid", "track"),
               "imu_grades": ("grid", "imu_grade"), "speeds_mps": ("grid", "speed_mps"),
               "filters": ("grid", "filter"),
               "sigma_pseudorange_m": ("grid", "sigma_pseudorange_m"),
               "sigma_range_rate_mps": ("grid", "sigma_range_rate_mps"),
               "outage_sets": ("grid", "outages")}


_STUDY_KEYS = {"name", "seed", "replicates", "scenario", "duration_s", "systems", "mode",
               "chunk_runs", "common_random_numbers"}
_GRID_KEYS = {"track", "imu_grade", "speed_mps", "filter", "sigma_pseudorange_m",
              "sigma_range_rate_mps", "outage_start_s", "outage_duration_s", "outages"}
_STREAMING_KEYS = {"segment_s"}
_TABLES = {"study": _STUDY_KEYS, "grid": _GRID_KEYS, "streaming": _STREAMING_KEYS}
_TOML_LOCATION = re.compile(r"\s*\(at (?:line (\d+), column (\d+)|end of document)\)\s*$")


def load_study_config(path: str | Path) -> StudyConfig:
    """Read a study file (module docstring).

    Raises
    ------
    ConfigError
        Located at the file, line and key of the problem (a byte that is not UTF-8: its
        line).
    OSError
        If the file cannot be read.
    """
    path = Path(path)
    return parse_study_config(read_text(path, error=ConfigError), path=path)


def parse_study_config(text: str, *, path: str | Path = "<study>") -> StudyConfig:
    """`load_study_config` of a file's text (`path` names it in messages and sets the
    folder of relative track paths)."""
    path = Path(path)
    data = _parse_toml(text, path)
    locate = _Locator(text, path)
    for table, value in data.items():
        if table not in _TABLES or not isinstance(value, dict):
            raise locate.error(table, None, f"unknown table [{table}]; expected "
                                            f"{', '.join(f'[{t}]' for t in _TABLES)}")
        for key in value:
            if key not in _TABLES[table]:
                raise locate.error(table, key, f"unknown key; expected one of "
                                               f"{', '.join(sorted(_TABLES[table]))}")
    study, grid = data.get("study", {}), data.get("grid", {})
    stream = data.get("streaming", {})
    fields_ = _study_fields(study, locate) | _grid_fields(study, grid, locate)
    fields_["segment_s"] = locate.get(stream, "streaming", "segment_s", _number,
                                      DEFAULT_SEGMENT_S)
    fields_["base_dir"] = path.parent
    for name in FIELD_CHECKS:
        try:
            check_field(name, fields_)
        except ConfigError as exc:
            table, key = _FIELD_KEYS[name]
            if name == "outage_sets" and "outages" not in grid:
                key = "outage_duration_s" if "outage_duration_s" in grid else None
            raise locate.error(table, key, exc.message) from None
    _check_size(fields_, locate)
    return StudyConfig(**fields_)


def _parse_toml(text: str, path: Path) -> dict:
    """The TOML document, or a `ConfigError` at the line tomllib names: ``not valid TOML``
    for a ``.toml`` file, ``not a TOML study file`` for any other (a track CSV given by
    mistake)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        found = _TOML_LOCATION.search(message)
        line = None
        if found:    # a line, or the end of the document: its last line
            line = int(found.group(1)) if found.group(1) else max(len(text.splitlines()), 1)
        what = "not valid TOML" if path.suffix.lower() == ".toml" else \
            "not a TOML study file"
        reason = _TOML_LOCATION.sub("", message)
        raise ConfigError(f"{what} ({reason})" if reason else what, path=path,
                          line=line) from None
    except RecursionError:
        raise ConfigError("not valid TOML: arrays or tables nested too deeply",
                          path=path) from None
    except ValueError as exc:           # tomllib's own limits, e.g. a 5000-digit integer
        reason = " ".join(str(exc).split(";")[0].split())
        raise ConfigError(f"not valid TOML: {reason}", path=path) from None


def _check_size(fields_: dict[str, Any], locate: "_Locator") -> None:
    """Refuse a study of more than `MAX_STUDY_RUNS` runs (a typo such as ``replicates =
    20000000000`` would otherwise fill the memory listing its runs)."""
    runs = fields_["replicates"]
    for axis in ("tracks", "imu_grades", "speeds_mps", "filters", "sigma_pseudorange_m",
                 "sigma_range_rate_mps", "outage_sets"):
        runs *= len(fields_[axis])
    if runs > MAX_STUDY_RUNS:
        raise locate.error("study", "replicates",
                           f"the grid times the replicates is {runs} runs, more than "
                           f"{MAX_STUDY_RUNS}: split the study")


def _study_fields(study: dict, locate: "_Locator") -> dict[str, Any]:
    get = functools.partial(locate.get, study, "study")
    scenario_name = get("scenario", _string, "paper2017")
    try:
        scenario = get_scenario(scenario_name)
    except ConfigError as exc:
        raise locate.error("study", "scenario", exc.message) from None
    return {"name": get("name", _string, "study"), "seed": get("seed", _int, 0),
            "replicates": get("replicates", _int, 1), "scenario": scenario_name,
            "duration_s": get("duration_s", _number, scenario.duration_s),
            "systems": get("systems", _string, DEFAULT_SYSTEMS), "mode": get("mode", _string, "memory"),
            "chunk_runs": get("chunk_runs", _int, DEFAULT_CHUNK_RUNS),
            "common_random_numbers": get("common_random_numbers", _bool, True)}


def _grid_fields(study: dict, grid: dict, locate: "_Locator") -> dict[str, Any]:
    scenario = get_scenario(study.get("scenario", "paper2017"))
    get = functools.partial(locate.get, grid, "grid")
    imu = scenario.imu_errors if isinstance(scenario.imu_errors, str) else scenario.imu.name
    out = {"tracks": get("track", _list_of(_string), (scenario.default_track,)),
           "imu_grades": get("imu_grade", _list_of(_string), (imu,)),
           "speeds_mps": get("speed_mps", _list_of(_number),
                             (scenario.profile.max_speed_mps,)),
           "filters": get("filter", _list_of(_string), ("constrained",)),
           "sigma_pseudorange_m": get("sigma_pseudorange_m", _list_of(_number),
                                      (scenario.sigma_pseudorange_m,)),
           "sigma_range_rate_mps": get("sigma_range_rate_mps", _list_of(_number),
                                       (scenario.sigma_range_rate_mps,))}
    if "outages" in grid:
        if "outage_start_s" in grid or "outage_duration_s" in grid:
            raise locate.error("grid", "outages", "give either outages or outage_start_s / "
                                                  "outage_duration_s, not both")
        out["outage_sets"] = get("outages", _list_of(_windows), None)
    elif "outage_start_s" in grid or "outage_duration_s" in grid:
        starts = get("outage_start_s", _list_of(_number), None)
        durations = get("outage_duration_s", _list_of(_number), None)
        if starts is None or durations is None:
            missing = "outage_start_s" if starts is None else "outage_duration_s"
            raise locate.error("grid", None, f"{missing} is missing (outages are start x "
                                             "duration)")
        out["outage_sets"] = tuple(((a, d),) for a in starts for d in durations)
    else:
        out["outage_sets"] = (scenario.outages,)
    return out


class _Locator:
    """Finds the line of a key in the file's text, and makes located errors."""

    def __init__(self, text: str, path: Path) -> None:
        self.path = path
        self.lines: dict[tuple[str, str | None], int] = {}
        table = ""
        for number, line in enumerate(text.splitlines(), start=1):
            header = re.match(r"\s*\[([^\[\]]+)\]\s*(#.*)?$", line)
            if header:
                table = header.group(1).strip()
                self.lines.setdefault((table, None), number)
                continue
            key = re.match(r"\s*([A-Za-z0-9_\-]+)\s*=", line)
            if key:
                self.lines.setdefault((table, key.group(1)), number)

    def error(self, table: str, key: str | None, message: str) -> ConfigError:
        line = self.lines.get((table, key)) or self.lines.get((table, None))
        column = f"{table}.{key}" if key else None
        return ConfigError(message, path=self.path, line=line, column=column)

    def get(self, values: dict, table: str, key: str, convert: Callable, default):
        if key not in values:
            return default
        try:
            return convert(values[key])
        except ConfigError as exc:
            raise self.error(table, key, exc.message) from None


def _string(value) -> str:
    if not isinstance(value, str):
        raise ConfigError(f"expected a string, got {value!r}")
    return value


def _int(value) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"expected an integer, got {value!r}")
    return value


def _bool(value) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"expected true or false, got {value!r}")
    return value


def _number(value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"expected a number, got {value!r}")
    return float(value)


def _windows(value) -> Outages:
    if not isinstance(value, list) or not all(
            isinstance(w, list) and len(w) == 2 for w in value):
        raise ConfigError(f"an outage set is a list of [start_s, duration_s] pairs, got "
                          f"{value!r}")
    return tuple((_number(a), _number(b)) for a, b in value)


def _list_of(convert: Callable) -> Callable:
    def parse(value) -> tuple:
        items = value if isinstance(value, list) else [value]
        return tuple(convert(v) for v in items)
    return parse

