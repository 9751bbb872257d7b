"""Broadcast orbits and clocks against precise SP3 products: differences and statistics.

`compare_with_precise` evaluates the broadcast ephemeris (`gnss_obs.ephemeris`) at every
epoch and satellite of an SP3 file and differences it with the precise values, resolved
into radial, along-track and cross-track components. `orbit_clock_statistics` summarises
them per system.

What the numbers mean:

* **orbits**: broadcast GPS orbits refer to the antenna phase centre, SP3 orbits to the
  centre of mass, so a GPS radial difference of up to ~1-2 m is partly that offset (not
  removed here: it is what a user of broadcast orbits sees);
* **clocks**: the broadcast clock (polynomial only: the relativistic eccentricity term is
  left out, as the SP3 clock convention leaves it out) minus the SP3 clock. Each product
  refers its clocks to its own signal combination and time datum (GPS broadcast: L1/L2
  P(Y); Galileo I/NAV: E1/E5b, F/NAV: E1/E5a; CODE: E1/E5a and its own realisation of
  GPST), so **the mean difference of each system is removed** (reported as
  ``clock_offset_ns``) and ``clock_rms_ns`` is the RMS of what remains.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.ephemeris import satellite_states, select_ephemeris

__all__ = ["compare_with_precise", "orbit_clock_statistics", "DIFFERENCE_COLUMNS"]

_NS = 1e9
#: Columns of `compare_with_precise`.
DIFFERENCE_COLUMNS = ["gps_time_s", "sv", "system", "age_s", "radial_m", "along_m", "cross_m",
                      "error_3d_m", "clock_diff_ns"]


def compare_with_precise(records: dict[str, pd.DataFrame], sp3_table: pd.DataFrame, *,
                         systems: str = "GRE", galileo_message: str = "inav") -> pd.DataFrame:
    """Broadcast minus precise orbit (RAC) and clock at the SP3 epochs.

    Parameters
    ----------
    records : dict of str to pandas.DataFrame
        `RinexNav.records`.
    sp3_table : pandas.DataFrame
        `Sp3.table` (``gps_time_s, sv, x_m, y_m, z_m, clock_s``).
    systems : str
        Systems to compare.
    galileo_message : {"inav", "fnav"}
        Galileo message to evaluate.

    Returns
    -------
    pandas.DataFrame
        `DIFFERENCE_COLUMNS`, one row per SP3 epoch × satellite with a valid broadcast record
        and precise position; ``age_s`` = t - the record's reference time (s), radial /
        along / cross and 3-D differences (m), clock difference (ns, NaN where the SP3
        clock is bad).
    """
    sp3 = sp3_table[sp3_table["sv"].str[0].isin(list(systems))]
    sp3 = sp3[np.isfinite(sp3[["x_m", "y_m", "z_m"]].to_numpy()).all(axis=1)]
    t = sp3["gps_time_s"].to_numpy()
    sel = select_ephemeris(records, sp3["sv"].to_numpy(), t, galileo_message=galileo_message)
    ok = sel["ephemeris_ok"].to_numpy()
    sel, sp3, t = sel[ok].reset_index(drop=True), sp3[ok], t[ok]
    states = satellite_states(sel, t)
    precise = sp3[["x_m", "y_m", "z_m"]].to_numpy()
    d = states.r_e - precise
    radial = precise / np.linalg.norm(precise, axis=1, keepdims=True)
    cross = np.cross(precise, states.v_e)
    cross /= np.linalg.norm(cross, axis=1, keepdims=True)
    along = np.cross(cross, radial)
    ref = np.where(sel["system"].to_numpy() == "R", sel["toc_gps_s"].to_numpy(dtype=float),
                   sel["toe_gps_s"].to_numpy(dtype=float) if "toe_gps_s" in sel else np.nan)
    clock = states.clock_s - states.relativity_s - sp3["clock_s"].to_numpy()
    return pd.DataFrame({
        "gps_time_s": t, "sv": sel["sv"].to_numpy(), "system": sel["system"].to_numpy(),
        "age_s": t - ref, "radial_m": np.einsum("ni,ni->n", d, radial),
        "along_m": np.einsum("ni,ni->n", d, along), "cross_m": np.einsum("ni,ni->n", d, cross),
        "error_3d_m": np.linalg.norm(d, axis=1), "clock_diff_ns": clock * _NS})


def _rms(x: pd.Series) -> float:
    v = x.to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v * v))) if v.size else float("nan")


def orbit_clock_statistics(diff: pd.DataFrame) -> pd.DataFrame:
    """Per-system orbit and clock statistics of `compare_with_precise` output.

    Returns
    -------
    pandas.DataFrame
        Index: system letter. Columns ``n, n_sv, orbit_rms_3d_m, radial_rms_m, along_rms_m,
        cross_rms_m, clock_offset_ns`` (mean broadcast - precise clock, removed before)
        ``clock_rms_ns``, and ``sisre_m`` (orbit-and-clock signal-in-space range error,
        ``sqrt((R - c·dt)² + (A² + C²)/49)``, a GPS-MEO weighting; the common clock offset
        removed).
    """
    rows = {}
    for system, g in diff.groupby("system"):
        offset = float(np.nanmean(g["clock_diff_ns"])) if g["clock_diff_ns"].notna().any() \
            else float("nan")
        clock = g["clock_diff_ns"] - offset
        clock_m = clock / _NS * SPEED_OF_LIGHT_MPS
        sisre = np.sqrt((g["radial_m"] - clock_m) ** 2
                        + (g["along_m"] ** 2 + g["cross_m"] ** 2) / 49.0)
        rows[system] = {"n": len(g), "n_sv": g["sv"].nunique(),
                        "orbit_rms_3d_m": _rms(g["error_3d_m"]),
                        "radial_rms_m": _rms(g["radial_m"]), "along_rms_m": _rms(g["along_m"]),
                        "cross_rms_m": _rms(g["cross_m"]), "clock_offset_ns": offset,
                        "clock_rms_ns": _rms(clock), "sisre_m": _rms(sisre)}
    return pd.DataFrame.from_dict(rows, orient="index")
