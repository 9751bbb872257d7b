"""Shared GNSS test data: the shipped real excerpt (data/gnss, see its README.md)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.sp3 import read_sp3
from trackmodel.earth import geodetic_to_ecef

GNSS_DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"


@pytest.fixture(scope="session")
def nav():
    """Broadcast navigation of 2020-11-29 (GPS, Galileo, GLONASS, BeiDou)."""
    return read_rinex_nav(GNSS_DATA / "broadcast_nav.rnx")


@pytest.fixture(scope="session")
def rover_obs():
    """Rover observations 12:40:00-12:42:59 GPST (urban drive, 1 Hz)."""
    return read_rinex_obs(GNSS_DATA / "rover_obs_1240.rnx")


@pytest.fixture(scope="session")
def cod_sp3():
    """CODE final orbits and clocks 11:00-14:30 (G, R, E)."""
    return read_sp3(GNSS_DATA / "COD21340_1100_1430.sp3")


@pytest.fixture(scope="session")
def igr_sp3():
    """IGS rapid orbits and clocks 11:00-14:30 (G)."""
    return read_sp3(GNSS_DATA / "igr21340_1100_1430.sp3")


@pytest.fixture(scope="session")
def reference():
    """Post-processed reference positions of the rover: gps_time_s and r_e (ECEF, m)."""
    df = pd.read_csv(GNSS_DATA / "reference_trajectory_1240.csv", comment="#", header=None,
                     names=["week", "sow", "lat_deg", "lon_deg", "h_m", "sdn", "sde", "sdu"])
    r_e = geodetic_to_ecef(np.deg2rad(df["lat_deg"].to_numpy()),
                           np.deg2rad(df["lon_deg"].to_numpy()), df["h_m"].to_numpy())
    return pd.DataFrame({"gps_time_s": df["week"] * 604_800.0 + df["sow"], "x_m": r_e[:, 0],
                         "y_m": r_e[:, 1], "z_m": r_e[:, 2]})
