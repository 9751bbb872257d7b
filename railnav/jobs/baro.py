"""A baro altimeter file checked against a navigation run (``railnav run --baro BARO.csv``).

The check itself is `railnav.evaluation.baro.baro_track_check` (the 2021 paper's monitor on rails);
this module feeds it from a run:

* `read_baro_csv`: the altimeter file, columns ``baro_h_m`` (m) and the time, either
  ``gps_time_s`` (GPS seconds, as ``estimates.csv`` of a file run) or ``time_s`` (s from the
  trip start), read as the railway sensors' files (`railnav.sensors.tables.read_timed_csv`);
  one-line located errors for anything else;
* `check_run_baro`: the track height and its σ at the baro times from the run's
  ``estimates.csv`` columns ``h_m``, ``sigma_up_m``, and the GNSS heights to check from a
  single-point solution of the run's observations (`gnss_obs.solve_spp`, which does not
  know the track);
* `baro_summary`: the ``baro`` entry of ``summary.json``;
* `add_run_baro` and `write_run_baro`: what ``railnav run --baro`` does with them: the
  check added to the run's summary (before `railnav.jobs.run.write_run` writes it), and
  ``baro.csv`` and ``baro_gnss.csv`` written beside the run's files.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from railnav.errors import ConfigError
from railnav.evaluation.baro import BaroCheck, BaroConfig, baro_track_check
from railnav.sensors.tables import TIME_COLUMNS, read_timed_csv
from trackmodel.errors import finite_column

__all__ = ["read_baro_csv", "check_run_baro", "baro_summary", "add_run_baro", "write_run_baro",
           "BARO_TIME_COLUMNS"]

#: Accepted time columns, in order of preference (those of every sensor file).
BARO_TIME_COLUMNS = TIME_COLUMNS


def read_baro_csv(path: str | os.PathLike) -> pd.DataFrame:
    """Read a baro file: ``time_s`` (or ``gps_time_s``) and ``baro_h_m``.

    Returns
    -------
    pandas.DataFrame
        The two columns, float, times strictly increasing; ``attrs["path"]`` the file.

    Raises
    ------
    ConfigError
        As `railnav.sensors.tables.read_timed_csv` (missing or empty file, no rows, no
        time column, a bad or not increasing time: its row); no ``baro_h_m`` column, or a
        height that is not a finite number (its row).
    """
    frame, time_col, times = read_timed_csv(path, "baro")
    if "baro_h_m" not in frame.columns:
        raise ConfigError("missing column baro_h_m", path=path)
    table = pd.DataFrame({time_col: times,
                          "baro_h_m": finite_column(frame, "baro_h_m", path=path,
                                                    error=ConfigError)})
    table.attrs["path"] = os.fspath(path)           # for messages about the file
    return table


def check_run_baro(outcome, baro: pd.DataFrame, *, obs=None, nav=None, measurement=None,
                   config: BaroConfig = BaroConfig()) -> BaroCheck:
    """The baro check of a run (module docstring).

    Parameters
    ----------
    outcome : railnav.jobs.run.RunOutcome
        A constrained or GNSS-only run (its estimates carry the track height).
    baro : pandas.DataFrame
        From `read_baro_csv`.
    obs, nav : gnss_obs.RinexObs, gnss_obs.RinexNav, optional
        Observations and navigation data for the GNSS heights (default: the run's own,
        simulated or read; without them only the bias is checked).
    measurement : gnss_obs.MeasurementConfig, optional
        The single-point solution's measurement model (default: the run's own, from its
        filter's configuration).
    config : BaroConfig

    Raises
    ------
    ConfigError
        Baro times outside the run.
    """
    result = outcome.result
    est = result.estimates
    t_est = est["time_s"].to_numpy()
    t = _relative_times(baro, result.start_gps_time_s)
    if t[0] < t_est[0] - 1.0 or t[-1] > t_est[-1] + 1.0:
        raise ConfigError(f"baro times [{t[0]:.1f}, {t[-1]:.1f}] s are outside the run "
                          f"[{t_est[0]:.1f}, {t_est[-1]:.1f}] s (from the trip start)",
                          path=baro.attrs.get("path"))
    h_track = np.interp(t, t_est, est["h_m"].to_numpy())
    sigma_track = np.interp(t, t_est, est["sigma_up_m"].to_numpy())
    if obs is None and outcome.trip is not None and outcome.trip.gnss is not None:
        obs, nav = outcome.trip.gnss.obs, outcome.trip.nav
    elif obs is None and outcome.data is not None:
        obs, nav = outcome.data.obs, outcome.data.nav
    if measurement is None:
        run_config = getattr(result.filter_object, "config", None)
        measurement = getattr(run_config, "measurement", None)
    gnss = _spp_heights(obs, nav, measurement, result.start_gps_time_s)
    return baro_track_check(t, baro["baro_h_m"].to_numpy(), h_track, sigma_track,
                            gnss_time_s=gnss[0], gnss_h_m=gnss[1], gnss_sigma_h_m=gnss[2],
                            config=config)


def baro_summary(check: BaroCheck) -> dict:
    """The ``baro`` entry of ``summary.json``: last bias and σ (m), flag counts."""
    return {"readings": int(check.time_s.size), "bias_m": float(check.bias_m[-1]),
            "sigma_bias_m": float(check.sigma_bias_m[-1]),
            "bias_flagged": int(check.bias_flag.sum()),
            "gnss_heights_checked": int(check.gnss_time_s.size),
            "gnss_heights_flagged": int(check.gnss_flag.sum())}


def add_run_baro(outcome, baro: pd.DataFrame, **kwargs) -> BaroCheck:
    """`check_run_baro` of `outcome` (keywords as its), with `baro_summary` added to the
    run's summary as ``baro`` (``summary.json`` of `railnav.jobs.run.write_run`, called
    after): ``railnav run --baro``."""
    check = check_run_baro(outcome, baro, **kwargs)
    outcome.summary["baro"] = baro_summary(check)
    return check


def write_run_baro(check: BaroCheck, out_dir: str | os.PathLike) -> list[Path]:
    """Write ``out_dir/baro.csv`` (`BaroCheck.to_frame`) and ``out_dir/baro_gnss.csv``
    (`BaroCheck.gnss_frame`) atomically; their paths."""
    from trackmodel.files import atomic_write_csv
    out = Path(out_dir)
    atomic_write_csv(out / "baro.csv", check.to_frame())
    atomic_write_csv(out / "baro_gnss.csv", check.gnss_frame())
    return [out / "baro.csv", out / "baro_gnss.csv"]


def _relative_times(baro: pd.DataFrame, start_gps_time_s: float) -> np.ndarray:
    if "gps_time_s" in baro.columns:
        return baro["gps_time_s"].to_numpy() - start_gps_time_s
    return baro["time_s"].to_numpy()


def _spp_heights(obs, nav, measurement, start_gps_time_s: float):
    """Single-point heights (time from the trip start, h, σ_h), empty without data."""
    if obs is None or nav is None:
        return (), (), ()
    from gnss_obs.spp import SppConfig, solve_spp
    from trackmodel.earth import ecef_to_geodetic
    cfg = SppConfig() if measurement is None else SppConfig(measurement=measurement)
    spp = solve_spp(obs, nav, cfg)
    ok = np.all(np.isfinite(spp.r_e), axis=1)
    h = ecef_to_geodetic(spp.r_e[ok])[2]
    sigma = np.sqrt(spp.cov_enu_m2[ok, 2, 2])
    keep = np.isfinite(sigma) & (sigma > 0)
    return (spp.gps_time_s[ok][keep] - start_gps_time_s, h[keep], sigma[keep])
