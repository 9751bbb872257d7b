"""Fixes from a CSV table (pandas' reader), including the Belgian train logs as shipped.

Columns are found by name (others are ignored):

* time: ``gps_time_s``, or ``timestamp`` (ISO 8601; labels without a zone are UTC; an
  offset such as ``+01:00`` is applied), or ``gps_week`` + ``gps_sow_s``;
* position: ``lat_deg``/``latitude``, ``lon_deg``/``longitude`` (WGS-84, deg), optional
  ``h_m`` (ellipsoidal, m);
* optional motion and σ (each σ finite and >= 0 where given): ``speed_mps``,
  ``course_deg``, ``v_east_mps``, ``v_north_mps``, ``v_up_mps``, ``sigma_east_m``,
  ``sigma_north_m``, ``sigma_up_m``, ``cov_en_m2``, ``sigma_speed_mps`` (what
  `gnss_obs.fixes.writers.write_fixes_csv` writes); without ``sigma_speed_mps`` (or where
  it is empty), a row's ``sigma_v_east_mps`` and ``sigma_v_north_mps`` (the velocity σ
  per axis that `gnss_obs.solve_spp`'s table, and so ``railnav spp``'s output, carries)
  give it as their RMS, ``√((σ_e² + σ_n²)/2)``: the σ of the velocity along a horizontal
  axis of any direction, as the fix-class table's σ_speed is (`gnss_obs.fixes.quality`);
* the fix class: ``quality`` (`gnss_obs.fixes.table.FIX_QUALITIES`), or a receiver flag in
  ``position_type`` (NovAtel-style names: `novatel_quality`); without either every fix
  is ``single``. A ``solution_status`` other than ``SOL_COMPUTED`` (NovAtel: the receiver
  computed no valid solution, e.g. ``INSUFFICIENT_OBS``, ``INTEGRITY_WARNING``) drops the
  row (counted as ``no_fix``).

The Belgian logs (``latitude, longitude, timestamp, position_type, solution_status``,
`DATA` README) read as they are.
"""
from __future__ import annotations

import logging
import os

import numpy as np
import pandas as pd

from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.table import (
    FIX_COLUMNS,
    FIX_QUALITIES,
    SIGMA_COLUMNS,
    FixLog,
    fix_frame,
)
from gnss_obs.gpstime import utc_datetime64_to_gps_time_s, week_sow_to_gps_time_s
from trackmodel.errors import finite_column

__all__ = ["read_fixes_csv", "novatel_quality", "SOLUTION_OK"]

log = logging.getLogger(__name__)

#: The NovAtel ``solution_status`` of a valid solution.
SOLUTION_OK = "SOL_COMPUTED"
#: Column name alternatives: ours first.
_ALIASES = {"lat_deg": ("lat_deg", "latitude"), "lon_deg": ("lon_deg", "longitude")}
_OPTIONAL = ("h_m", "speed_mps", "course_deg", "v_east_mps", "v_north_mps", "v_up_mps",
             "sigma_east_m", "sigma_north_m", "sigma_up_m", "cov_en_m2", "sigma_speed_mps")
#: The velocity σ per axis (east, north) of an SPP table, m/s: the speed σ without one.
_VELOCITY_SIGMAS = ("sigma_v_east_mps", "sigma_v_north_mps")
#: NovAtel position types by the fix class they mean (substring rules, in this order).
_NOVATEL_RULES = (("NONE", None), ("INT", "rtk_fixed"), ("RTKFIXED", "rtk_fixed"),
                  ("FLOAT", "rtk_float"), ("PPP", "rtk_float"), ("PSRDIFF", "dgps"),
                  ("WAAS", "dgps"), ("SBAS", "dgps"), ("DGPS", "dgps"), ("SINGLE", "single"),
                  ("PSRSP", "single"), ("PROPAGATED", "dead_reckoning"),
                  ("DEAD", "dead_reckoning"))


def novatel_quality(flag: str) -> str | None:
    """The fix class of a NovAtel-style position type (``NARROW_INT``, ``L1_FLOAT``,
    ``PSRDIFF``, ``SINGLE``, ``PROPAGATED``, ``INS_RTKFIXED``, ...), one of our own class
    names, or None for ``NONE`` (no solution).

    Raises
    ------
    GnssInputError
        For a flag no rule knows.
    """
    text = str(flag).strip()
    if text in FIX_QUALITIES:
        return text
    upper = text.upper()
    for pattern, quality in _NOVATEL_RULES:
        if pattern in upper:
            return quality
    raise GnssInputError(f"unknown position type {text!r}")


def read_fixes_csv(path: str | os.PathLike) -> FixLog:
    """Read a CSV fix table (module docstring).

    Returns
    -------
    gnss_obs.fixes.table.FixLog
        Without the σ the file lacks (`gnss_obs.fixes.read.read_fixes` fills them).

    Raises
    ------
    GnssInputError
        Empty file, no time or position column, a value that is not a number or not a
        time, an unknown quality flag (each located by row and column).
    """
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise GnssInputError(f"not a CSV fix table ({' '.join(str(exc).split())})",
                             path=path) from None
    skipped = {}
    if "solution_status" in raw.columns:
        ok = raw["solution_status"].str.strip().to_numpy() == SOLUTION_OK
        skipped["no_fix"] = int((~ok).sum())
        raw = raw[ok].reset_index(drop=True)
    columns = {name: finite_column(raw, _column(raw, name, path), path=path,
                                   error=GnssInputError) for name in ("lat_deg", "lon_deg")}
    for name in _OPTIONAL:
        if name in raw.columns:
            columns[name] = _optional_column(raw, name, path)
            if name in SIGMA_COLUMNS:
                _check_sigma(columns[name], name, path)
    _speed_sigma_from_velocity(raw, columns, path)
    times, suffix = _times(raw, path)
    columns.update(times)
    quality, flag = _quality(raw, path)
    keep = np.array([q is not None for q in quality], dtype=bool)
    skipped["no_fix"] = skipped.get("no_fix", 0) + int((~keep).sum())
    columns["quality"], columns["flag"] = np.asarray(quality, dtype=object), flag
    columns = {k: np.asarray(v)[keep] for k, v in columns.items() if k in FIX_COLUMNS}
    table, dup = fix_frame(columns, path=path)
    skipped["duplicate_time"] = dup
    return FixLog(table, "csv", os.fspath(path), "GPS" if "timestamp" not in raw.columns
                  else "UTC", utc_suffix=suffix, skipped=skipped)


def _check_sigma(values: np.ndarray, name: str, path) -> np.ndarray:
    """`values` of σ column `name`, which must be finite and >= 0 where given (an empty
    cell gives none; 0, a σ below the file's resolution, as railnav's own exports of a
    track-constrained axis write it, is kept)."""
    bad = np.flatnonzero(~np.isnan(values) & ~(np.isfinite(values) & (values >= 0)))
    if bad.size:
        raise GnssInputError(f"{float(values[bad[0]])!r} is not a σ (finite, >= 0)",
                             path=path, row=int(bad[0]) + 1, column=name)
    return values


def _speed_sigma_from_velocity(raw: pd.DataFrame, columns: dict, path) -> None:
    """``sigma_speed_mps`` from the velocity σ per axis where the file gives no speed σ
    (module docstring); unchanged without both velocity σ columns."""
    if not set(_VELOCITY_SIGMAS) <= set(raw.columns):
        return
    east, north = (_check_sigma(_optional_column(raw, name, path), name, path)
                   for name in _VELOCITY_SIGMAS)
    from_velocity = np.sqrt(0.5 * (east ** 2 + north ** 2))
    own = columns.get("sigma_speed_mps", np.full(len(raw), np.nan))
    columns["sigma_speed_mps"] = np.where(np.isfinite(own), own, from_velocity)


def _column(raw: pd.DataFrame, name: str, path) -> str:
    for alias in _ALIASES[name]:
        if alias in raw.columns:
            return alias
    raise GnssInputError(f"no {' or '.join(_ALIASES[name])} column (columns: "
                         f"{', '.join(raw.columns)})", path=path)


def _optional_column(raw: pd.DataFrame, name: str, path) -> np.ndarray:
    """Floats, empty cells as NaN; anything else that is not a number is an error."""
    text = raw[name].str.strip()
    values = pd.to_numeric(text.replace("", np.nan), errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(np.isnan(values) & (text.to_numpy() != "")
                         & (text.str.lower().to_numpy() != "nan"))
    if bad.size:
        raise GnssInputError(f"{raw[name].iloc[bad[0]]!r} is not a number", path=path,
                             row=int(bad[0]) + 1, column=name)
    return values


def _times(raw: pd.DataFrame, path) -> tuple[dict, str]:
    """``gps_time_s`` (and ``timestamp`` as written) and the UTC suffix of the labels."""
    if "gps_time_s" in raw.columns:
        return {"gps_time_s": finite_column(raw, "gps_time_s", path=path,
                                            error=GnssInputError)}, ""
    if "timestamp" in raw.columns:
        text = raw["timestamp"].str.strip()
        stamps = pd.to_datetime(text, format="ISO8601", utc=True, errors="coerce")
        bad = np.flatnonzero(stamps.isna().to_numpy())
        if bad.size:
            raise GnssInputError(f"{text.iloc[bad[0]]!r} is not an ISO 8601 time", path=path,
                                 row=int(bad[0]) + 1, column="timestamp")
        naive = stamps.dt.tz_convert(None).to_numpy(dtype="datetime64[ns]")
        zoned = text.str.contains(r"(?:Z|[+-]\d\d:?\d\d)$", regex=True).any()
        return {"gps_time_s": utc_datetime64_to_gps_time_s(naive),
                "timestamp": text.to_numpy(dtype=object)}, "Z" if zoned else ""
    if {"gps_week", "gps_sow_s"} <= set(raw.columns):
        week, sow = (finite_column(raw, c, path=path, error=GnssInputError)
                     for c in ("gps_week", "gps_sow_s"))
        return {"gps_time_s": week_sow_to_gps_time_s(week, sow)}, ""
    raise GnssInputError("no time column: need gps_time_s, timestamp (ISO 8601) or "
                         "gps_week + gps_sow_s", path=path)


def _quality(raw: pd.DataFrame, path) -> tuple[list, np.ndarray]:
    """Fix class (None: no fix) and the file's flag of each row."""
    name = "quality" if "quality" in raw.columns else (
        "position_type" if "position_type" in raw.columns else None)
    if name is None:
        log.info("%s: no quality or position_type column: every fix is 'single'", path)
        return ["single"] * len(raw), np.full(len(raw), "", dtype=object)
    flags = raw[name].str.strip().to_numpy(dtype=object)
    classes = {}
    for i, flag in enumerate(flags):
        if flag not in classes:
            try:
                classes[flag] = novatel_quality(flag)
            except GnssInputError as exc:
                raise GnssInputError(exc.message, path=path, row=i + 1, column=name) from None
    return [classes[f] for f in flags], flags
