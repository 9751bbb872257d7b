"""Files of a GNSS simulation: the RINEX observation header and the two RINEX files.

Simulated data take the same reading path as real data (`read_rinex_obs`,
`read_rinex_nav`): `write_simulation` writes the observation table with `write_rinex_obs`
and the navigation data used with `write_rinex_nav`.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from gnss_obs.rinex_nav import RinexNav
from gnss_obs.rinex_obs import ObsHeader
from gnss_obs.rinex_write import write_rinex_nav, write_rinex_obs
from gnss_obs.sim_result import GnssSimulation

__all__ = ["simulation_header", "write_simulation"]

#: Observation kinds a simulation writes per signal: code, Doppler, C/N0.
_KINDS = ("C", "D", "S")


def simulation_header(table: pd.DataFrame, *, signals: dict[str, str], r0_e: np.ndarray,
                      glonass_slots: dict[str, int], leap_seconds: int | None) -> ObsHeader:
    """The observation header of a simulated table.

    Parameters
    ----------
    table : pandas.DataFrame
        Simulated observation table (`gnss_obs.rinex_obs` columns).
    signals : dict of str to str
        Signal per system letter (``{"G": "1C"}``).
    r0_e : ndarray, shape (3,)
        Receiver position at the first epoch, ECEF, m (``APPROX POSITION XYZ``).
    glonass_slots : dict of str to int
        GLONASS satellite -> frequency channel.
    leap_seconds : int or None
        GPST - UTC, s.
    """
    t = np.unique(table["gps_time_s"].to_numpy())
    # the distinct letters (``unique``: iterating the 10 812 rows of a text column, as
    # ``set`` does, took ~3-20 ms of every simulated run)
    systems = sorted(table["system"].unique())
    return ObsHeader(obs_types={s: [k + signals[s] for k in _KINDS] for s in systems},
                     first_obs_gps_time_s=float(t[0]), marker_name="SIMULATED",
                     receiver="railnav simulate_gnss", approx_position_e=np.array(r0_e, float),
                     interval_s=float(np.median(np.diff(t))) if t.size > 1 else None,
                     time_system="GPS", leap_seconds=leap_seconds,
                     glonass_slots=dict(sorted(glonass_slots.items())))


def write_simulation(out_dir: str | os.PathLike, simulation: GnssSimulation, nav: RinexNav, *,
                     obs_name: str = "gnss_obs.rnx",
                     nav_name: str = "gnss_nav.rnx") -> tuple[Path, Path]:
    """Write a simulation's observations and the navigation data it used (RINEX 3.04).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Existing directory.
    simulation : GnssSimulation
    nav : RinexNav
        The navigation data given to `simulate_gnss`.
    obs_name, nav_name : str
        File names inside `out_dir`.

    Returns
    -------
    (obs_path, nav_path) : tuple of Path
        Both written atomically (`write_rinex_obs`, `write_rinex_nav`).
    """
    out = Path(out_dir)
    obs_path, nav_path = out / obs_name, out / nav_name
    write_rinex_obs(obs_path, simulation.obs.header, simulation.obs.table)
    write_rinex_nav(nav_path, nav)
    return obs_path, nav_path
