"""The compiled satellite terms (`railnav.filters.guess_kernel`) against the NumPy
evaluation of the same model (`gnss_obs.guess_terms.evaluate_numpy`), over configurations
and receivers around the globe, and against the textbook for the geometry."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ekf.compiled import compiler_available
from gnss_obs.constants import OMEGA_E_GPS, SPEED_OF_LIGHT_MPS
from gnss_obs.guess_terms import (
    OUTPUTS,
    evaluate_numpy,
    receiver_terms,
    satellite_columns,
    uses_klobuchar,
)
from gnss_obs.measurements import MeasurementConfig
from railnav.filters.guess_kernel import compiled_evaluator
from trackmodel.earth import ecef_to_geodetic, geodetic_to_ecef

pytestmark = pytest.mark.skipif(not compiler_available(), reason="no C compiler")

KLOBUCHAR = (np.array([1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8]),
             np.array([9.0112e4, 0.0, -1.9661e5, -6.5536e4]))
CONFIGS = (MeasurementConfig(),
           MeasurementConfig(sigma_model="additive", sigma_pr_elevation_m=2.0,
                             sigma_pr_cn0_m=1.0, cn0_ref_dbhz=45.0),
           MeasurementConfig(ionosphere="iono-free", troposphere=False,
                             elevation_weighting=False, sigma_pr_floor_m=0.5),
           MeasurementConfig(ionosphere="none", cn0_ref_dbhz=np.inf))


class _States:
    def __init__(self, r_e, v_e):
        self.r_e, self.v_e = r_e, v_e


def _scene(rng, n_guesses=5, n_sats=11):
    """Receivers at random latitudes/longitudes/heights; satellites on a 26 560 km sphere
    above each (any elevation, some below the horizon), with velocities of ~3.9 km/s."""
    lat = rng.uniform(-1.4, 1.4, n_guesses)
    lon = rng.uniform(-np.pi, np.pi, n_guesses)
    h = rng.uniform(-50.0, 3000.0, n_guesses)
    receivers = geodetic_to_ecef(lat, lon, h)
    direction = rng.normal(size=(n_sats, 3)) + receivers[0] / 6.4e6
    r_sat = 2.656e7 * direction / np.linalg.norm(direction, axis=1)[:, None]
    v_sat = 3.9e3 * np.cross(r_sat, rng.normal(size=3))
    v_sat /= np.linalg.norm(v_sat, axis=1)[:, None] / 3.9e3
    meas = {"frequency_hz": rng.choice([1575.42e6, 1176.45e6], n_sats),
            "frequency2_hz": np.full(n_sats, 1227.60e6),
            "cn0_dbhz": rng.uniform(25.0, 50.0, n_sats)}
    return receivers, r_sat, v_sat, meas


@pytest.mark.parametrize("config", CONFIGS)
def test_compiled_terms_are_the_numpy_ones_to_the_last_bits(config):
    """Every output at 5 receivers × 11 satellites (positions, velocities, delays, angles,
    σ) within 1e-14 relative (libm and CasADi's ``x·x²`` against NumPy's loops), angles
    within 1e-14 rad; the delays of the models the configuration uses only."""
    rng = np.random.default_rng(3)
    receivers, r_sat, v_sat, meas = _scene(rng)
    sat = np.ascontiguousarray(satellite_columns(_States(r_sat, v_sat), meas, config))
    rx = np.array([receiver_terms(r.tolist(), *(float(a) for a in ecef_to_geodetic(r)),
                                  1.2e9 + 3.7e4, config, KLOBUCHAR) for r in receivers])
    for with_klobuchar in dict.fromkeys((False, uses_klobuchar(config, KLOBUCHAR))):
        compiled = compiled_evaluator(config)(rx, sat, config, with_klobuchar)
        numpy = evaluate_numpy(rx, sat, config, with_klobuchar)
        for name, got, want in zip(OUTPUTS, compiled, numpy):
            assert got.shape == want.shape, name
            if name in ("elevation", "azimuth"):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-14, err_msg=name)
            else:
                np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-12, err_msg=name)
        assert np.all(compiled[2] > 0) if with_klobuchar else np.all(compiled[2] == 0)
        assert np.all(compiled[3] > 0) if config.troposphere else np.all(compiled[3] == 0)


def test_compiled_geometry_is_the_textbook_one():
    """The compiled flight time, Sagnac rotation and look angles of each guess: R_z(Ω τ)
    of the satellite, asin(u / |los|) and atan2(e, n) in the ENU frame, per guess (a
    guess's rows are those of its own call, to the bit)."""
    config = CONFIGS[0]
    rng = np.random.default_rng(5)
    receivers, r_sat, v_sat, meas = _scene(rng, n_guesses=3, n_sats=7)
    sat = np.ascontiguousarray(satellite_columns(_States(r_sat, v_sat), meas, config))
    places = [tuple(float(a) for a in ecef_to_geodetic(r)) for r in receivers]
    rx = np.array([receiver_terms(r.tolist(), *p, 1.2e9, config, KLOBUCHAR)
                   for r, p in zip(receivers, places)])
    evaluate = compiled_evaluator(config)
    together = evaluate(rx, sat, config, True)
    for k, (r, (lat, lon, _)) in enumerate(zip(receivers, places)):
        alone = evaluate(rx[k:k + 1], sat, config, True)
        for got, want in zip(together, alone):
            np.testing.assert_array_equal(got[k], want[0])
        enu = np.array([[-math.sin(lon), math.cos(lon), 0.0],
                        [-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon),
                         math.cos(lat)],
                        [math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon),
                         math.sin(lat)]])
        for i in range(len(r_sat)):
            a = OMEGA_E_GPS * np.linalg.norm(r_sat[i] - r) / SPEED_OF_LIGHT_MPS
            rot = np.array([[math.cos(a), math.sin(a), 0.0],
                            [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
            np.testing.assert_allclose(together[0][k, i], rot @ r_sat[i], rtol=1e-14)
            np.testing.assert_allclose(together[1][k, i], rot @ v_sat[i], rtol=1e-13)
            e, n, u = enu @ (rot @ r_sat[i] - r)
            assert together[4][k, i] == pytest.approx(math.asin(u / math.hypot(e, n, u)),
                                                      abs=1e-12)
            assert together[5][k, i] == pytest.approx(math.atan2(e, n) % (2 * math.pi),
                                                      abs=1e-12)


def test_a_pickled_evaluator_computes_the_same():
    """A `CompiledTerms` sent to another process (pickled without its libraries) loads
    its own and gives the same numbers, to the bit."""
    import pickle
    config = CONFIGS[1]
    receivers, r_sat, v_sat, meas = _scene(np.random.default_rng(8), n_guesses=2)
    sat = np.ascontiguousarray(satellite_columns(_States(r_sat, v_sat), meas, config))
    rx = np.array([receiver_terms(r.tolist(), *(float(a) for a in ecef_to_geodetic(r)),
                                  1.2e9, config, KLOBUCHAR) for r in receivers])
    evaluate = compiled_evaluator(config)
    copy = pickle.loads(pickle.dumps(evaluate))
    for got, want in zip(copy(rx, sat, config, True), evaluate(rx, sat, config, True)):
        np.testing.assert_array_equal(got, want)
