"""SPP results against a reference trajectory: errors, accuracy figures, plot.

Shared by ``railnav spp --ref``, the notebooks and ``benchmarks/bench_spp_real.py`` so
that every figure is computed one way:

* position errors in the local East-North-Up frame of the reference point, at the epochs
  both have: each solution epoch is matched to the nearest reference epoch within
  `MATCH_TOLERANCE_S` (receivers such as u-blox tag epochs a few ms off whole seconds,
  while references sit on whole seconds); the reference is not interpolated, so a match
  at offset δt adds up to ``speed × δt`` (≤ 0.2 m at 10 m/s) to the error;
* horizontal RMS and 95th percentile, vertical RMS;
* speed error: |v| of the solution minus the reference speed from **central differences**
  of the reference positions ``(r[k+1] - r[k-1]) / (t[k+1] - t[k-1])`` (only where both
  neighbours are within `MAX_DIFF_GAP_S`).

`read_reference_trajectory` accepts the project's columns (``gps_time_s, lat_deg, lon_deg,
h_m``) or the GPS week / seconds-of-week layout of post-processing tools (the shared
``reference_trajectory.csv``: ``# GPSW,GPSSoW,latitude(deg),longitude(deg),height(m),...``).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gnss_obs.constants import WEEK_S
from railnav.errors import ConfigError
from trackmodel.earth import C_n_e, geodetic_to_ecef
from trackmodel.errors import finite_column
from trackmodel.files import atomic_write
from trackmodel.textfile import read_csv_table

__all__ = ["read_reference_trajectory", "spp_errors", "SppAccuracy", "accuracy_summary",
           "plot_spp", "MAX_DIFF_GAP_S", "MATCH_TOLERANCE_S", "match_epochs"]

#: Largest time step (s) on either side of an epoch for a central-difference speed.
MAX_DIFF_GAP_S = 1.5
#: Largest |t_solution - t_reference| for a match, s (module docstring).
MATCH_TOLERANCE_S = 0.02
_PROJECT_COLUMNS = ("gps_time_s", "lat_deg", "lon_deg", "h_m")
_WEEK_COLUMNS = ("week", "sow", "lat_deg", "lon_deg", "h_m")


def _week_layout(path) -> pd.DataFrame:
    """The GPS week / seconds-of-week layout: headerless rows after ``#`` comments; every
    value a finite number (located by row, 1-based among the data rows, and column)."""
    df = read_csv_table(path, error=ConfigError, comment="#", header=None, dtype=str,
                        skipinitialspace=True)
    first = str(df.iat[0, 0]).strip() if df.size else ""
    if df.shape[1] < len(_WEEK_COLUMNS) or (first and not _is_number(first)):
        # too few columns, or a header line where a GPS week should be: another layout
        raise ConfigError(f"expected columns {', '.join(_PROJECT_COLUMNS)}, or headerless "
                          "rows of GPS week, seconds of week, latitude (deg), longitude "
                          "(deg), height (m)", path=path)
    df = df.iloc[:, :len(_WEEK_COLUMNS)].set_axis(list(_WEEK_COLUMNS), axis=1)
    values = {c: finite_column(df, c, path=path, error=ConfigError) for c in _WEEK_COLUMNS}
    out = pd.DataFrame({"gps_time_s": values["week"] * float(WEEK_S) + values["sow"]})
    for c in _PROJECT_COLUMNS[1:]:
        out[c] = values[c]
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_reference_trajectory(path: str | os.PathLike) -> pd.DataFrame:
    """Read a reference trajectory (module docstring for the two layouts).

    Returns
    -------
    pandas.DataFrame
        ``gps_time_s, lat_deg, lon_deg, h_m`` sorted by time.

    Raises
    ------
    ConfigError
        Empty file, missing columns, a value that is not a finite number or a latitude
        outside ±90° (with the row); a byte that is not UTF-8 or a row with more fields
        than the first (with the line).
    """
    head = read_csv_table(path, error=ConfigError, nrows=0, comment=None, dtype=str)
    if set(_PROJECT_COLUMNS) <= set(head.columns):
        df = read_csv_table(path, error=ConfigError, usecols=list(_PROJECT_COLUMNS), dtype=str)
    else:
        df = _week_layout(path)
    if df.empty:
        raise ConfigError("reference file has no rows", path=path)
    for c in df.columns:
        df[c] = finite_column(df, c, path=path, error=ConfigError)
    lat_deg = df["lat_deg"].to_numpy()
    outside = np.flatnonzero(np.abs(lat_deg) > 90.0)
    if outside.size:
        raise ConfigError(f"must satisfy -90 <= lat_deg <= 90, got {float(lat_deg[outside[0]])!r}",
                          path=path, row=int(outside[0]) + 1, column="lat_deg")
    return df.sort_values("gps_time_s").reset_index(drop=True)


def _reference_velocity(t: np.ndarray, r_e: np.ndarray) -> np.ndarray:
    v = np.full_like(r_e, np.nan)
    if len(t) < 3:
        return v
    back, ahead = t[1:-1] - t[:-2], t[2:] - t[1:-1]
    ok = (back <= MAX_DIFF_GAP_S) & (ahead <= MAX_DIFF_GAP_S)
    v[1:-1][ok] = ((r_e[2:] - r_e[:-2]) / (t[2:] - t[:-2])[:, None])[ok]
    return v


def match_epochs(t_solution_s: np.ndarray, t_reference_s: np.ndarray, *,
                 tolerance_s: float = MATCH_TOLERANCE_S) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i_sol, i_ref)`` pairing each solution epoch with the nearest reference
    epoch when they are at most `tolerance_s` apart (reference sorted by time)."""
    t_sol = np.asarray(t_solution_s, dtype=float)
    t_ref = np.asarray(t_reference_s, dtype=float)
    if t_ref.size == 0 or t_sol.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    right = np.clip(np.searchsorted(t_ref, t_sol), 1, max(t_ref.size - 1, 1))
    left = right - 1
    nearest = np.where(np.abs(t_ref[np.minimum(right, t_ref.size - 1)] - t_sol)
                       < np.abs(t_ref[left] - t_sol), np.minimum(right, t_ref.size - 1), left)
    ok = np.abs(t_ref[nearest] - t_sol) <= tolerance_s
    return np.flatnonzero(ok), nearest[ok]


def spp_errors(solution: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """Per-epoch errors of an ``spp.csv`` table against a reference.

    Parameters
    ----------
    solution : pandas.DataFrame
        ``gps_time_s, lat_deg, lon_deg, h_m`` and optionally ``v_east_mps, v_north_mps,
        v_up_mps`` (`SppResult.to_frame`).
    reference : pandas.DataFrame
        `read_reference_trajectory` output.

    Returns
    -------
    pandas.DataFrame
        ``gps_time_s, east_m, north_m, up_m, horizontal_m, speed_error_mps`` (NaN where the
        solution has no fix or no velocity, or the reference speed is unknown), for the
        solution epochs with a reference epoch within `MATCH_TOLERANCE_S`.
    """
    ref = reference.copy()
    lat, lon = np.deg2rad(ref["lat_deg"].to_numpy()), np.deg2rad(ref["lon_deg"].to_numpy())
    r_ref = geodetic_to_ecef(lat, lon, ref["h_m"].to_numpy())
    speed_ref = np.linalg.norm(_reference_velocity(ref["gps_time_s"].to_numpy(), r_ref), axis=1)
    i_sol, i_ref = match_epochs(solution["gps_time_s"].to_numpy(), ref["gps_time_s"].to_numpy())
    sol = solution.iloc[i_sol]
    r_sol = geodetic_to_ecef(np.deg2rad(sol["lat_deg"].to_numpy()),
                             np.deg2rad(sol["lon_deg"].to_numpy()), sol["h_m"].to_numpy())
    enu = np.einsum("nji,nj->ni", C_n_e(lat[i_ref], lon[i_ref]), r_sol - r_ref[i_ref])
    speed_error = np.full(i_sol.size, np.nan)
    if {"v_east_mps", "v_north_mps", "v_up_mps"} <= set(sol.columns):
        v = sol[["v_east_mps", "v_north_mps", "v_up_mps"]].to_numpy()
        speed_error = np.linalg.norm(v, axis=1) - speed_ref[i_ref]
    return pd.DataFrame({"gps_time_s": sol["gps_time_s"].to_numpy(), "east_m": enu[:, 0],
                         "north_m": enu[:, 1], "up_m": enu[:, 2],
                         "horizontal_m": np.hypot(enu[:, 0], enu[:, 1]),
                         "speed_error_mps": speed_error})


@dataclass(frozen=True)
class SppAccuracy:
    """Accuracy figures of a solution against a reference (NaN when nothing to compare)."""

    n_epochs: int
    horizontal_rms_m: float
    horizontal_95_m: float
    vertical_rms_m: float
    n_speed: int
    speed_rms_mps: float

    def lines(self) -> list[str]:
        """Human-readable summary lines."""
        return [f"epochs compared      {self.n_epochs}",
                f"horizontal RMS       {self.horizontal_rms_m:.2f} m",
                f"horizontal 95 %      {self.horizontal_95_m:.2f} m",
                f"vertical RMS         {self.vertical_rms_m:.2f} m",
                f"speed RMS            {self.speed_rms_mps:.3f} m/s ({self.n_speed} epochs)"]


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def accuracy_summary(errors: pd.DataFrame) -> SppAccuracy:
    """RMS / 95 % figures of `spp_errors` output (epochs without a fix are left out)."""
    fixed = errors[np.isfinite(errors["horizontal_m"])]
    h = fixed["horizontal_m"].to_numpy()
    speed = errors["speed_error_mps"].to_numpy()
    return SppAccuracy(
        n_epochs=len(fixed), horizontal_rms_m=_rms(h),
        horizontal_95_m=float(np.percentile(h, 95)) if h.size else float("nan"),
        vertical_rms_m=_rms(fixed["up_m"].to_numpy()), n_speed=int(np.isfinite(speed).sum()),
        speed_rms_mps=_rms(speed))


def plot_spp(solution: pd.DataFrame, path: str | os.PathLike,
             errors: pd.DataFrame | None = None, reference: pd.DataFrame | None = None) -> None:
    """`railnav.evaluation.spp_plots.spp_figure` (map; errors with ±3σ, VPL and HPL, or the
    σ without a reference; satellites) written atomically as PNG to `path`."""
    from railnav.evaluation.spp_plots import spp_figure
    fig = spp_figure(solution, errors, reference)
    with atomic_write(path, "wb", encoding=None) as fh:
        fig.savefig(fh, format="png", dpi=110)
