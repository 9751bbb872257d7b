r"""What a recorded IMU log is: its layout, units, mounting and noise (`ImuSpec`, TOML).

A real IMU log is not railnav's ``imu.csv``: other column names, times in ms or GPS
seconds, accelerometers in g, gyros in deg/s, increments (Δv, Δθ) instead of rates, a sensor
mounted upside down. `ImuSpec` says all of that once; `strapdown.imu_log.read_imu_log` reads
a log with it. Its TOML form (``--imu-spec FILE.toml``; every table and key optional)::

    [columns]
    time = "t_us"               # time column (default time_s)
    accel = ["ax", "ay", "az"]  # specific force or Δv columns, sensor axes
    gyro = ["gx", "gy", "gz"]   # angular rate or Δθ columns, sensor axes

    [units]
    time = "us"                 # s (default), ms, us, ns
    time_reference = "gps"      # trip (default: s from the trip start) or gps (GPS s)
    kind = "rates"              # rates (default) or increments
    accel = "g"                 # rates: m/s^2 (default), g, mg; increments: m/s
    gyro = "deg/s"              # rates: rad/s (default), deg/s, deg/h; increments: rad, deg

    [timing]
    rate_hz = 200.0             # nominal rate (default: the median step)
    gap_report_s = 0.05         # gaps longer than this are listed (default 5 intervals)
    max_gap_s = 1.0             # a longer gap is an error (default 1 s)

    [mounting]
    axes = ["x", "-y", "-z"]    # vehicle x, y, z as signed sensor axes (here: FRD sensor)
    rpy_deg = [0.0, 0.5, 0.0]   # then the sensor's small rotation in the vehicle

    [noise]                     # what the filter assumes (else --imu-grade)
    grade = "tactical"          # start from a preset of strapdown.imu_errors, and/or:
    gyro_arw_deg_rthr = 0.15
    gyro_bias_instability_deg_h = 0.8
    gyro_bias_tau_s = 300.0
    accel_noise_density_ug_rthz = 60.0
    accel_bias_instability_ug = 40.0

**Mounting.** The vehicle frame is the body frame of the project (x forward, y left, z up).
``axes`` maps sensor axes to vehicle axes (``"-y"``: the vehicle's axis is minus the sensor's
y). ``rpy_deg`` is the rotation of the (re-labelled) sensor frame in the vehicle frame with
the attitude convention of `strapdown.euler` relative to the vehicle: its x axis points
``yaw`` to the right of the vehicle's x and ``pitch`` above it, ``roll`` right-handed about
it: ``C_v_s = R_z(−ψ) R_y(−θ) R_x(φ)``, and ``f_v = C_v_s A f_s`` with ``A`` the axes map.

**Noise keys** (`NOISE_KEYS`): every field of `strapdown.imu_errors.ImuErrors` in its SI unit
(``accel_noise_density_mps2_rthz``, ...), or the datasheet forms of this table, converted
once here; a quantity given twice is an error.

========================================  ===============================================
datasheet key (unit)                      `ImuErrors` field
========================================  ===============================================
``gyro_arw_deg_rthr`` (°/√h)               ``gyro_noise_density_radps_rthz``
``gyro_bias_deg_h`` (°/h)                  ``gyro_bias_radps``
``gyro_bias_instability_deg_h`` (°/h)      ``gyro_bias_instability_radps``
``accel_vrw_mps_rthr`` (m/s/√h)            ``accel_noise_density_mps2_rthz``
``accel_noise_density_ug_rthz`` (µg/√Hz)   ``accel_noise_density_mps2_rthz``
``accel_bias_mg`` (mg)                     ``accel_bias_mps2``
``accel_bias_instability_ug`` (µg)         ``accel_bias_instability_mps2``
========================================  ===============================================
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields, replace

import numpy as np
import numpy.typing as npt

from strapdown.errors import ImuInputError, StrapdownError
from strapdown.imu import IMU_COLUMNS
from strapdown.imu_errors import STANDARD_GRAVITY_MPS2, ImuErrors, imu_grade

__all__ = ["ImuSpec", "read_imu_spec", "imu_spec_from_dict", "noise_errors", "RATE_UNITS", "INCREMENT_UNITS",
           "TIME_UNITS", "NOISE_KEYS", "DEFAULT_MAX_GAP_S", "DEFAULT_GAP_REPORT_INTERVALS"]

Array = npt.NDArray[np.float64]

_DEG = math.pi / 180.0
#: Seconds per unit of the time column.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: SI factor of each rate unit: (accelerometer units -> m/s², gyro units -> rad/s).
RATE_UNITS = ({"m/s^2": 1.0, "g": STANDARD_GRAVITY_MPS2, "mg": 1e-3 * STANDARD_GRAVITY_MPS2},
              {"rad/s": 1.0, "deg/s": _DEG, "deg/h": _DEG / 3600.0})
#: SI factor of each increment unit: (Δv -> m/s, Δθ -> rad).
INCREMENT_UNITS = ({"m/s": 1.0}, {"rad": 1.0, "deg": _DEG})
#: Datasheet noise keys: name -> (`ImuErrors` field, factor to SI).
NOISE_KEYS = {
    "gyro_arw_deg_rthr": ("gyro_noise_density_radps_rthz", _DEG / 60.0),
    "gyro_bias_deg_h": ("gyro_bias_radps", _DEG / 3600.0),
    "gyro_bias_instability_deg_h": ("gyro_bias_instability_radps", _DEG / 3600.0),
    "accel_vrw_mps_rthr": ("accel_noise_density_mps2_rthz", 1.0 / 60.0),
    "accel_noise_density_ug_rthz": ("accel_noise_density_mps2_rthz",
                                    1e-6 * STANDARD_GRAVITY_MPS2),
    "accel_bias_mg": ("accel_bias_mps2", 1e-3 * STANDARD_GRAVITY_MPS2),
    "accel_bias_instability_ug": ("accel_bias_instability_mps2", 1e-6 * STANDARD_GRAVITY_MPS2),
}
#: A gap longer than this is an error, s: an inertial filter integrating through a longer
#: blind interval on interpolated inputs would be guessing (an option of the spec).
DEFAULT_MAX_GAP_S = 1.0
#: Gaps of at least this many nominal intervals are listed (four samples or more missing).
DEFAULT_GAP_REPORT_INTERVALS = 5.0
_AXES = ("x", "y", "z")
_TABLES = {"columns": ("time", "accel", "gyro"),
           "units": ("time", "time_reference", "kind", "accel", "gyro"),
           "timing": ("rate_hz", "gap_report_s", "max_gap_s"),
           "mounting": ("axes", "rpy_deg")}


@dataclass(frozen=True)
class ImuSpec:
    """A recorded IMU log's layout, units, mounting and assumed noise (module docstring).

    Parameters
    ----------
    time_column : str
    accel_columns, gyro_columns : tuple of 3 str
        Sensor-axis columns of the specific force (Δv) and angular rate (Δθ).
    time_unit : str
        A key of `TIME_UNITS`.
    time_reference : str
        ``trip`` (s from the trip start) or ``gps`` (GPS seconds: the log's first sample
        becomes ``time_s = 0`` and gives the trip's start time).
    kind : str
        ``rates`` (instantaneous samples) or ``increments`` (Δv, Δθ over the interval that
        ends at each time stamp).
    accel_unit, gyro_unit : str or None
        Keys of `RATE_UNITS` (rates) or `INCREMENT_UNITS` (increments); None: SI (m/s²
        and rad/s, or m/s and rad).
    rate_hz : float or None
        Nominal sample rate, Hz (None: 1 / the median step).
    gap_report_s : float or None
        Gaps longer than this are listed, s (None: `DEFAULT_GAP_REPORT_INTERVALS` intervals).
    max_gap_s : float
        A longer gap is an error, s (``inf``: none).
    axes : tuple of 3 str
        Vehicle x, y, z as signed sensor axes (``"x"``, ``"-z"``, ...).
    mounting_rpy_deg : tuple of 3 float
        Roll, pitch, yaw of the sensor in the vehicle, deg.
    errors : ImuErrors or None
        The noise the filter assumes (None: not given; the run needs a grade).
    name : str
        Where the spec came from (its file, or ``"imu.csv"`` for railnav's own layout).
    """

    time_column: str = IMU_COLUMNS[0]
    accel_columns: tuple[str, str, str] = tuple(IMU_COLUMNS[1:4])  # type: ignore[assignment]
    gyro_columns: tuple[str, str, str] = tuple(IMU_COLUMNS[4:7])   # type: ignore[assignment]
    time_unit: str = "s"
    time_reference: str = "trip"
    kind: str = "rates"
    accel_unit: str | None = None
    gyro_unit: str | None = None
    rate_hz: float | None = None
    gap_report_s: float | None = None
    max_gap_s: float = DEFAULT_MAX_GAP_S
    axes: tuple[str, str, str] = ("x", "y", "z")
    mounting_rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    errors: ImuErrors | None = field(default=None, compare=False)
    name: str = "imu.csv"

    def __post_init__(self) -> None:
        _choice("time unit", self.time_unit, TIME_UNITS)
        _choice("time_reference", self.time_reference, ("trip", "gps"))
        _choice("kind", self.kind, ("rates", "increments"))
        units = RATE_UNITS if self.kind == "rates" else INCREMENT_UNITS
        for name, table in (("accel_unit", units[0]), ("gyro_unit", units[1])):
            if getattr(self, name) is None:              # the SI unit of the kind
                object.__setattr__(self, name, next(iter(table)))
        _choice(f"accelerometer unit of {self.kind}", self.accel_unit, units[0])
        _choice(f"gyro unit of {self.kind}", self.gyro_unit, units[1])
        for name in ("accel_columns", "gyro_columns", "axes", "mounting_rpy_deg"):
            if len(getattr(self, name)) != 3:
                raise StrapdownError(f"{name} must have 3 entries, got {getattr(self, name)!r}")
        columns = (self.time_column, *self.accel_columns, *self.gyro_columns)
        if not all(isinstance(c, str) and c for c in columns) or len(set(columns)) != 7:
            raise StrapdownError(f"the 7 columns must be distinct names, got {columns!r}")
        self.axes_matrix()
        for name in ("rate_hz", "gap_report_s"):
            value = getattr(self, name)
            if value is not None and not (_number(value) and 0 < value < math.inf):
                raise StrapdownError(f"{name} must be a finite number > 0, got {value!r}")
        if not (_number(self.max_gap_s) and self.max_gap_s > 0):
            raise StrapdownError(f"max_gap_s must be > 0, got {self.max_gap_s!r}")
        if not all(_number(a) and abs(a) <= 180.0 for a in self.mounting_rpy_deg):
            raise StrapdownError(f"rpy_deg must be 3 angles within ±180°, got "
                                 f"{self.mounting_rpy_deg!r}")

    @property
    def accel_factor(self) -> float:
        """SI factor of the accelerometer columns (to m/s², or m/s for increments)."""
        return (RATE_UNITS if self.kind == "rates" else INCREMENT_UNITS)[0][self.accel_unit]

    @property
    def gyro_factor(self) -> float:
        """SI factor of the gyro columns (to rad/s, or rad for increments)."""
        return (RATE_UNITS if self.kind == "rates" else INCREMENT_UNITS)[1][self.gyro_unit]

    def axes_matrix(self) -> Array:
        """``A`` (3, 3): vehicle axes from sensor axes (module docstring).

        Raises
        ------
        StrapdownError
            Unknown axis names, or axes that are not a permutation of x, y, z.
        """
        A = np.zeros((3, 3))
        for row, text in enumerate(self.axes):
            name = str(text).strip().lstrip("+")
            sign = -1.0 if name.startswith("-") else 1.0
            name = name.lstrip("-")
            if name not in _AXES:
                raise StrapdownError(f"axes entries are x, y, z with an optional sign, got "
                                     f"{text!r}")
            A[row, _AXES.index(name)] = sign
        if sorted(np.flatnonzero(A.any(axis=0))) != [0, 1, 2]:
            raise StrapdownError(f"axes must use each of x, y, z once, got {self.axes!r}")
        return A

    def mounting_matrix(self) -> Array:
        """``C_v_s A`` (3, 3): vehicle-frame vectors from sensor-frame columns."""
        from strapdown.euler import C_b_n
        roll, pitch, yaw = np.radians(np.asarray(self.mounting_rpy_deg, dtype=float))
        C_vs = np.asarray(C_b_n(0.0, 0.0, 0.0)).T @ np.asarray(C_b_n(yaw, pitch, roll))
        return C_vs @ self.axes_matrix()


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and \
        not math.isnan(value)


def _choice(what: str, value, allowed) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise StrapdownError(f"{what} must be one of {', '.join(allowed)}, got {value!r}")


def read_imu_spec(path: str | os.PathLike) -> ImuSpec:
    """Read an IMU spec file (TOML, module docstring).

    Raises
    ------
    ImuInputError
        Not UTF-8 or not TOML (located at its line), an unknown table or key, a value of
        the wrong type or out of range (named by its table and key).
    """
    import tomllib

    from trackmodel.textfile import read_text
    text = read_text(path, error=ImuInputError)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ImuInputError(f"not valid TOML ({exc})", path=path) from None
    except (RecursionError, ValueError) as exc:
        raise ImuInputError(f"not valid TOML ({type(exc).__name__})", path=path) from None
    return imu_spec_from_dict(doc, name=str(path), path=path)


def imu_spec_from_dict(doc: dict, *, name: str = "spec", path=None) -> ImuSpec:
    """`ImuSpec` from the parsed TOML document (tables as in the module docstring).

    Raises
    ------
    ImuInputError
        As `read_imu_spec`.
    """
    unknown = sorted(set(doc) - set(_TABLES) - {"noise"})
    if unknown:
        raise ImuInputError(f"unknown table [{unknown[0]}] (tables: "
                            f"{', '.join([*_TABLES, 'noise'])})", path=path)
    get = _Getter(doc, path)
    columns, units = get.table("columns"), get.table("units")
    timing, mounting = get.table("timing"), get.table("mounting")
    values = {"time_column": columns.get("time", IMU_COLUMNS[0]),
              "accel_columns": _triple(columns.get("accel", IMU_COLUMNS[1:4]), "accel", path),
              "gyro_columns": _triple(columns.get("gyro", IMU_COLUMNS[4:7]), "gyro", path),
              "time_unit": units.get("time", "s"),
              "time_reference": units.get("time_reference", "trip"),
              "kind": units.get("kind", "rates"),
              "rate_hz": timing.get("rate_hz"), "gap_report_s": timing.get("gap_report_s"),
              "max_gap_s": timing.get("max_gap_s", DEFAULT_MAX_GAP_S),
              "axes": _triple(mounting.get("axes", ("x", "y", "z")), "axes", path),
              "mounting_rpy_deg": _triple(mounting.get("rpy_deg", (0.0, 0.0, 0.0)), "rpy_deg",
                                          path)}
    values["accel_unit"], values["gyro_unit"] = units.get("accel"), units.get("gyro")
    try:
        spec = ImuSpec(**values, name=name)
    except (StrapdownError, TypeError) as exc:
        raise ImuInputError(str(exc), path=path) from None
    if "noise" in doc:
        spec = replace(spec, errors=noise_errors(get.table("noise", free=True), path=path))
    return spec


def _triple(value, key: str, path) -> tuple:
    """A TOML array of three values as a tuple."""
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ImuInputError(f"{key} must be an array of 3 values, got {value!r}", path=path)
    return tuple(value)


class _Getter:
    """Tables of a spec document, their keys checked."""

    def __init__(self, doc: dict, path) -> None:
        self.doc, self.path = doc, path

    def table(self, name: str, *, free: bool = False) -> dict:
        value = self.doc.get(name, {})
        if not isinstance(value, dict):
            raise ImuInputError(f"[{name}] must be a table", path=self.path)
        extra = [] if free else sorted(set(value) - set(_TABLES[name]))
        if extra:
            raise ImuInputError(f"unknown key {extra[0]!r} in [{name}] (keys: "
                                f"{', '.join(_TABLES[name])})", path=self.path)
        return value


def noise_errors(table: dict, *, path=None) -> ImuErrors:
    """The `ImuErrors` of a ``[noise]`` table: ``grade`` (a preset, default all zero) with
    the given fields replaced (SI names or the datasheet keys of `NOISE_KEYS`).

    Raises
    ------
    ImuInputError
        An unknown key or grade, a quantity given twice, a value that is not a number >= 0.
    """
    names = {f.name for f in fields(ImuErrors)} - {"name"}
    base_name = table.get("grade")
    if base_name is not None and not isinstance(base_name, str):
        raise ImuInputError(f"[noise] grade must be a preset name, got {base_name!r}",
                            path=path)
    try:
        base = imu_grade(base_name) if base_name is not None else ImuErrors()
    except StrapdownError as exc:
        raise ImuInputError(f"[noise] grade: {exc}", path=path) from None
    values: dict[str, float] = {}
    for key, value in table.items():
        if key == "grade":
            continue
        target, factor = (key, 1.0) if key in names else NOISE_KEYS.get(key, (None, 1.0))
        if target is None:
            raise ImuInputError(f"unknown key {key!r} in [noise] (ImuErrors fields or "
                                f"{', '.join(NOISE_KEYS)})", path=path)
        if target in values:
            raise ImuInputError(f"[noise] gives {target} twice (through {key!r})", path=path)
        if not (_number(value) and 0 <= value < math.inf):
            raise ImuInputError(f"[noise] {key} must be a finite number >= 0, got {value!r}",
                                path=path)
        values[target] = float(value) * factor
    try:
        return replace(base, **values, name=f"spec {path}" if path is not None else "spec")
    except StrapdownError as exc:
        raise ImuInputError(f"[noise]: {exc}", path=path) from None
