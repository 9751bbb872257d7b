"""Measurement selection: signal preference, Doppler to range rate, ionosphere-free pairs."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.errors import GnssError
from gnss_obs.measurements import MeasurementConfig, glonass_channels, select_measurements

L1_HZ, L2_HZ = 1575.42e6, 1227.60e6


def _table(rows):
    cols = ["gps_time_s", "sv", "signal", "pseudorange_m", "doppler_hz", "cn0_dbhz"]
    df = pd.DataFrame(rows, columns=cols)
    df["system"] = df["sv"].str[0]
    df["prn"] = df["sv"].str[1:].astype(int)
    df["band"] = df["signal"].str[0].astype(int)
    return df


def test_doppler_to_range_rate_and_signal_preference():
    """ρ̇ = -λ D (ARCHITECTURE.md); GPS prefers 1C, falls back to 1W; unknown signals ignored."""
    t = _table([(0.0, "G01", "1C", 2.1e7, 1000.0, 45.0), (0.0, "G01", "1W", 2.1e7 + 1, 0, 40),
                (0.0, "G02", "1W", 2.2e7, -500.0, 44.0), (0.0, "G03", "5Q", 2.3e7, 0, 40)])
    m = select_measurements(t, MeasurementConfig(systems="G"))
    assert list(m["sv"]) == ["G01", "G02"] and list(m["signal"]) == ["1C", "1W"]
    np.testing.assert_allclose(m["range_rate_mps"], [-SPEED_OF_LIGHT_MPS / L1_HZ * 1000.0,
                                                     SPEED_OF_LIGHT_MPS / L1_HZ * 500.0])


def test_iono_free_removes_a_first_order_delay():
    """P1 = ρ + I, P2 = ρ + (f1/f2)² I  ->  (f1² P1 - f2² P2)/(f1² - f2²) = ρ."""
    rho, iono = 2.2e7, 7.3
    t = _table([(0.0, "G05", "1C", rho + iono, 10.0, 45.0),
                (0.0, "G05", "2W", rho + (L1_HZ / L2_HZ) ** 2 * iono, 8.0, 40.0),
                (0.0, "G07", "1C", rho, 10.0, 45.0)])
    m = select_measurements(t, MeasurementConfig(systems="G", ionosphere="iono-free"))
    assert list(m["sv"]) == ["G05"]  # G07 has no second frequency
    assert m["pseudorange_m"].iloc[0] == pytest.approx(rho, abs=1e-6)
    assert m["band2"].iloc[0] == 2 and m["frequency2_hz"].iloc[0] == L2_HZ


def test_glonass_needs_its_channel():
    t = _table([(0.0, "R07", "1C", 2.0e7, 100.0, 40.0), (0.0, "R08", "1C", 2.0e7, 100.0, 40.0)])
    m = select_measurements(t, MeasurementConfig(systems="R"), glonass_channels={"R07": 5})
    assert list(m["sv"]) == ["R07"]
    assert m["frequency_hz"].iloc[0] == pytest.approx(1602e6 + 5 * 0.5625e6)


def test_glonass_channels_from_header_over_nav(nav):
    ch = glonass_channels({"R07": 4}, nav.records)
    assert ch["R07"] == 4 and ch["R08"] == 6


@pytest.mark.parametrize("kwargs", [dict(systems="GX"), dict(systems=""), dict(systems="GG"),
                                    dict(ionosphere="nequick"), dict(sigma_pr_m=0.0),
                                    dict(sigma_rr_mps=float("nan")),
                                    dict(galileo_message="cnav")])
def test_config_validation(kwargs):
    with pytest.raises(GnssError):
        MeasurementConfig(**kwargs)


def test_real_excerpt_selection(rover_obs):
    """On the rover excerpt: one GPS L1 C/A and one Galileo E1 row per tracked satellite."""
    m = select_measurements(rover_obs.table, MeasurementConfig(systems="GE"))
    assert set(m["signal"]) == {"1C"}
    assert not m.duplicated(["gps_time_s", "sv"]).any()
    assert (m.groupby("gps_time_s")["system"].apply(lambda s: (s == "G").sum()) >= 5).all()
