"""The guess-dependent part of an epoch's preparation (`gnss_obs.guess_terms`) against the
textbook: flight time and Sagnac rotation by a rotation matrix, look angles from the local
ENU frame, Klobuchar step by step (IS-GPS-200N §20.3.3.5.2.5) in plain Python."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gnss_obs.constants import OMEGA_E_GPS, SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.epoch import measurement_sigmas, prepare_epoch, prepare_epochs, split_epochs
from gnss_obs.measurements import MeasurementConfig, select_measurements
from gnss_obs.transmission import transmit_states
from trackmodel.earth import ecef_to_geodetic

T_1240 = 2134 * WEEK_S + 45_600.0


def _klobuchar_textbook(alpha, beta, lat, lon, el, az, t):
    """IS-GPS-200N Figure 20-4, one satellite, in Python floats (s)."""
    e = el / math.pi
    psi = 0.0137 / (e + 0.11) - 0.022
    phi_i = min(max(lat / math.pi + psi * math.cos(az), -0.416), 0.416)
    lam_i = lon / math.pi + psi * math.sin(az) / math.cos(phi_i * math.pi)
    phi_m = phi_i + 0.064 * math.cos((lam_i - 1.617) * math.pi)
    t_local = (4.32e4 * lam_i + t % WEEK_S) % 86400.0
    f = 1.0 + 16.0 * (0.53 - e) ** 3
    amp = max(sum(a * phi_m ** n for n, a in enumerate(alpha)), 0.0)
    per = max(sum(b * phi_m ** n for n, b in enumerate(beta)), 72000.0)
    x = 2.0 * math.pi * (t_local - 50400.0) / per
    if abs(x) >= 1.57:
        return f * 5e-9
    return f * (5e-9 + amp * (1.0 - x ** 2 / 2.0 + x ** 4 / 24.0))


@pytest.fixture(scope="module")
def epoch_1240(nav, rover_obs):
    cfg = MeasurementConfig(systems="G", ionosphere="klobuchar")
    table = rover_obs.table
    meas = select_measurements(table[table["gps_time_s"] == T_1240], cfg)
    return cfg, split_epochs(meas, nav.records, cfg)[0]


def test_prepared_epoch_is_the_textbook_geometry_and_ionosphere(nav, rover_obs, epoch_1240):
    """Each satellite at the rover's approximate position: its position at transmission
    turned by R_z(Ω τ), τ = |r_tx - r_rx| / c; elevation asin(u / |los|) and azimuth
    atan2(e, n) in the ENU frame of the geodetic latitude and longitude; ionosphere c ×
    Klobuchar × (f_L1 / f)² (1 for L1)."""
    cfg, epoch = epoch_1240
    r_rx = np.asarray(rover_obs.header.approx_position_e, dtype=float)
    klob = (nav.header.iono_gps_alpha, nav.header.iono_gps_beta)
    p = prepare_epoch(epoch, cfg, r_rx_e=r_rx, klobuchar=klob)
    states, _ = transmit_states(epoch, cfg)
    lat, lon, _ = (float(a) for a in ecef_to_geodetic(r_rx))
    enu = np.array([[-math.sin(lon), math.cos(lon), 0.0],
                    [-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon),
                     math.cos(lat)],
                    [math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon),
                     math.sin(lat)]])
    assert len(p) == len(epoch) == 8
    for i in range(len(p)):
        tau = np.linalg.norm(states.r_e[i] - r_rx) / SPEED_OF_LIGHT_MPS
        a = OMEGA_E_GPS * tau
        rot = np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0],
                        [0.0, 0.0, 1.0]])
        np.testing.assert_allclose(p.sat_pos_e[i], rot @ states.r_e[i], rtol=1e-14)
        np.testing.assert_allclose(p.sat_vel_e[i], rot @ states.v_e[i], rtol=1e-13)
        e, n, u = enu @ (rot @ states.r_e[i] - r_rx)
        el = math.asin(u / math.sqrt(e * e + n * n + u * u))
        az = math.atan2(e, n) % (2.0 * math.pi)
        assert p.elevation[i] == pytest.approx(el, abs=1e-12)
        assert p.azimuth[i] == pytest.approx(az, abs=1e-12)
        iono = SPEED_OF_LIGHT_MPS * _klobuchar_textbook(klob[0], klob[1], lat, lon, el, az,
                                                        T_1240)
        assert p.iono_m[i] == pytest.approx(iono, rel=1e-12)


def test_unknown_guesses_have_no_angles_delays_or_weighting(nav, rover_obs, epoch_1240):
    """A guess at the Earth's centre, one 200 km up and a coarse one: NaN look angles, no
    delays, the σ of the zenith (`measurement_sigmas` at 90°); the satellites still
    turned by their own flight time (from the guess); a known guess among them keeps its
    own numbers, to the bit."""
    cfg, epoch = epoch_1240
    r_rx = np.asarray(rover_obs.header.approx_position_e, dtype=float)
    klob = (nav.header.iono_gps_alpha, nav.header.iono_gps_beta)
    up = r_rx * (1.0 + 2e5 / np.linalg.norm(r_rx))
    found = prepare_epochs(epoch, cfg, r_rx_e=np.array([np.zeros(3), r_rx, up]),
                           klobuchar=klob)
    coarse = prepare_epoch(epoch, cfg, r_rx_e=r_rx, klobuchar=klob, coarse=True)
    states, _ = transmit_states(epoch, cfg)
    zenith = measurement_sigmas(np.full(len(epoch), np.pi / 2), epoch.meas["cn0_dbhz"], cfg,
                                frequency_hz=epoch.meas["frequency_hz"],
                                frequency2_hz=epoch.meas["frequency2_hz"])
    for guess, p in ((np.zeros(3), found[0]), (up, found[2]), (r_rx, coarse)):
        assert np.isnan(p.elevation).all() and np.isnan(p.azimuth).all()
        assert (p.iono_m == 0).all() and (p.tropo_m == 0).all()
        np.testing.assert_allclose((p.sigma_pr_m, p.sigma_rr_mps), zenith, rtol=1e-15)
        tau = np.linalg.norm(states.r_e - guess, axis=1) / SPEED_OF_LIGHT_MPS
        np.testing.assert_allclose(np.linalg.norm(p.sat_pos_e[:, :2], axis=1),
                                   np.linalg.norm(states.r_e[:, :2], axis=1), rtol=1e-15)
        np.testing.assert_allclose(
            np.arctan2(states.r_e[:, 1], states.r_e[:, 0])
            - np.arctan2(p.sat_pos_e[:, 1], p.sat_pos_e[:, 0]), OMEGA_E_GPS * tau,
            rtol=1e-6)
    alone = prepare_epoch(epoch, cfg, r_rx_e=r_rx, klobuchar=klob)
    for name, value in vars(alone).items():
        np.testing.assert_array_equal(getattr(found[1], name), value, strict=True)
