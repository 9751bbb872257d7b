"""Each epoch's pseudoranges solved alone on a piece's track, against the reference: the
along-track error the rows themselves hold, split into the track's mismatch and the code
error (`bench_real_pieces.py`'s ``on_track_code``).

For an epoch with the reference at ``r`` and its projection on the track at ``s_ref``:

* ``mismatch_m``: the ranges from ``r`` solved on the track (`tests.support.track_offsets.
  on_track_shift`, ``δs`` with one clock per system): where a receiver off the track (a car
  in another lane, beside the track's end, above or below it) puts ``s`` with no
  measurement error at all;
* ``code_m``: the measured pseudoranges' misfit at ``r`` solved the same way (their code
  error, multipath, orbits, atmosphere left; the part common to a system's rows is its
  clock's);
* ``total_m``: both, the rows' own answer less ``s_ref`` (the single-epoch solution on the
  track, linear in the misfits);
* ``sigma_m``: its σ from the rows' white variances (`gnss_obs.MeasurementConfig`'s σ model).

The rows: the filter's systems, signals, corrections, elevation mask and σ
(`railnav.config.NavigatorConfig`); every satellite with a pseudorange, no fault
exclusion, no inflation. The ranges' change along the track is the difference of the
ranges from the track's points 0.5 m either side of ``s_ref`` (inside its ends).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from gnss_obs.residuals import known_position_residuals
from tests.support.track_offsets import on_track_shift
from trackmodel.earth import geodetic_to_ecef

__all__ = ["on_track_code_errors", "on_track_summary", "rows_at_worst", "COLUMNS"]

COLUMNS = ("gps_time_s", "mismatch_m", "code_m", "total_m", "sigma_m")
#: Half the step of the along-track difference, m.
HALF_STEP_M = 0.5


def _residuals(obs, nav, config, times: np.ndarray, r_e: np.ndarray) -> pd.DataFrame:
    """Pseudorange residuals (less each epoch's median: a clock, solved again below) at
    the positions `r_e`, indexed by time and satellite."""
    table = known_position_residuals(obs, nav, config.measurement, times_s=times, r_e=r_e,
                                     elevation_mask_deg=config.elevation_mask_deg)
    table = table[np.isfinite(table["pr_residual_m"])]
    return table.assign(gps_time_s=np.round(table["gps_time_s"], 3)).set_index(
        ["gps_time_s", "sv"])


def on_track_code_errors(obs, nav, config, track, reference: pd.DataFrame,
                         s_ref: np.ndarray) -> pd.DataFrame:
    """`COLUMNS` of the module docstring at each reference epoch (rows of `reference`:
    ``gps_time_s``, ``lat_deg``, ``lon_deg``, ``h_m``; `s_ref` their projections on
    `track`), one row per epoch with more rows than unknowns."""
    times = np.round(reference["gps_time_s"].to_numpy(float), 3)
    r_ref = np.asarray(geodetic_to_ecef(np.radians(reference["lat_deg"].to_numpy(float)),
                                             np.radians(reference["lon_deg"].to_numpy(float)),
                                             reference["h_m"].to_numpy(float)))
    s = np.asarray(s_ref, float)
    ahead = np.clip(s + HALF_STEP_M, 2 * HALF_STEP_M, track.length_m)
    res = {name: _residuals(obs, nav, config, times, r)
           for name, r in (("ref", r_ref), ("track", track.at(s).r_e),
                           ("ahead", track.at(ahead).r_e),
                           ("behind", track.at(ahead - 2 * HALF_STEP_M).r_e))}
    common = res["ref"].index
    for name in ("track", "ahead", "behind"):
        common = common.intersection(res[name].index)
    ref, on, ahead_r, behind_r = (res[k].loc[common] for k in ("ref", "track", "ahead",
                                                               "behind"))
    # residuals are pseudorange − range: range(a) − range(b) = residual(b) − residual(a)
    frame = pd.DataFrame({
        "drho_ds": (behind_r["pr_residual_m"] - ahead_r["pr_residual_m"]) / (2 * HALF_STEP_M),
        "mismatch": on["pr_residual_m"] - ref["pr_residual_m"],
        "code": ref["pr_residual_m"], "variance": ref["sigma_pr_m"] ** 2,
        "system": ref["system"]})
    rows = []
    for t, e in frame.groupby(level="gps_time_s", sort=True):
        args = (e["drho_ds"].to_numpy(), e["variance"].to_numpy(), e["system"].to_numpy())
        mismatch, sigma = on_track_shift(args[0], e["mismatch"].to_numpy(), *args[1:])
        code, _ = on_track_shift(args[0], e["code"].to_numpy(), *args[1:])
        if np.isfinite(sigma):
            rows.append((float(t), mismatch, code, mismatch + code, sigma))
    return pd.DataFrame(rows, columns=list(COLUMNS))


def on_track_summary(e: pd.DataFrame) -> dict:
    """The piece's pseudoranges solved epoch by epoch on its track
    (`on_track_code_errors`, `e`): RMS and largest |error| along the track
    of that solution (``along_track``), of its part from the reference's offset from the
    track (``mismatch``) and of its part from the code errors (``code``), and the epochs
    it has."""
    out = {"epochs": int(len(e))}
    for key, column in (("along_track", "total_m"), ("mismatch", "mismatch_m"),
                        ("code", "code_m")):
        x = e[column].to_numpy()
        out[f"{key}_rms_m"] = float(np.sqrt(np.mean(x ** 2)))
        out[f"{key}_max_m"] = float(np.max(np.abs(x)))
    return out


def rows_at_worst(row: dict, e: pd.DataFrame) -> None:
    """Each solution's worst epoch (``at_horizontal_max``) with the rows' own answer there
    (`on_track_code_errors`' ``total_m``, ``mismatch_m``, ``code_m`` as ``rows_on_track``; NaN
    where the epoch has none)."""
    e = e.set_index(np.round(e["gps_time_s"]))
    for name in ("spp", "gnss-only", "fixes"):
        worst = row[name]["at_horizontal_max"]
        t = round(worst["gps_time_s"])
        worst["rows_on_track"] = {k: float(e.at[t, k]) if t in e.index else float("nan")
                                  for k in ("total_m", "mismatch_m", "code_m")}
