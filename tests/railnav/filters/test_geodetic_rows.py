"""GNSS rows of the unconstrained filter (railnav/filters/geodetic_rows.py).

References: `trackmodel.earth.geodetic_to_ecef` / `C_n_e` (NumPy, the owners) for the
symbolic geodetic forms; `gnss_obs.observables.predict_pseudorange` /
`predict_range_rate` evaluated at ``r_e = geodetic_to_ecef(lat, lon, h)``,
``v_e = C_n_e v_n`` composed here in NumPy (an independent composition of the
observation equations) for the rows; central differences of that composition for
their Jacobians.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gnss_obs.epoch import PreparedEpoch
from gnss_obs.observables import predict_pseudorange, predict_range_rate
from railnav.filters.geodetic_rows import (
    C_n_e_sx,
    build_geodetic_rows,
    geodetic_to_ecef_sx,
)
from railnav.filters.gnss_rows import pseudorange_parameters, range_rate_parameters
from railnav.filters.unconstrained_model import build_unconstrained_model
from trackmodel.earth import WGS84, C_n_e, geodetic_to_ecef, sphere

#: Both forms evaluate the same closed form in double precision: ~1e-16 relative of
#: 6.4e6 m, i.e. a few nm; 1e-6 m leaves room for rounding in a different order.
ATOL_ECEF_M = 1e-6
#: Rotation matrix entries are O(1): rounding only.
ATOL_ROTATION = 1e-14
#: Same observation equations evaluated at the same receiver: rounding of 2e7 m ranges.
ATOL_RANGE_M = 1e-6
ATOL_RATE_MPS = 1e-9
#: Central differences: steps of 1e-6 rad (6 m) and 1 m (or m/s). Truncation is
#: ~(step/2e7 m)² relative (1e-13); rounding is ε·ρ/(2 step) with ρ ≲ 3e7 m the largest
#: value differenced (range plus clocks): 3e-3 per rad, 3e-9 per metre. The Jacobian must
#: match to 1e-6 relative, or to 10× that rounding bound absolute.
RTOL_JACOBIAN = 1e-6
RANGE_SCALE_M = 3e7
STEP = {"lat": 1e-6, "lon": 1e-6, "h": 1.0, "v_E": 1.0, "v_N": 1.0, "v_U": 1.0,
        "clock_bias": 1.0, "clock_drift": 1.0, "isb_E": 1.0}


def _points(rng, n=50):
    """Random geodetic points; |lat| ≤ 89.9° (the poles are excluded: lon undefined)."""
    lat = np.radians(rng.uniform(-89.9, 89.9, n))
    lon = np.radians(rng.uniform(-180.0, 180.0, n))
    h = rng.uniform(-500.0, 9000.0, n)
    return lat, lon, h


@pytest.mark.parametrize("earth", [WGS84, sphere()], ids=["wgs84", "sphere"])
def test_symbolic_geodetic_to_ecef_matches_the_numpy_owner(earth, rng):
    lat, lon, h = _points(rng)
    s_lat, s_lon, s_h = ca.SX.sym("lat"), ca.SX.sym("lon"), ca.SX.sym("h")
    fun = ca.Function("g2e", [s_lat, s_lon, s_h], [geodetic_to_ecef_sx(s_lat, s_lon, s_h,
                                                                        earth=earth)])
    got = np.array([np.array(fun(*p)).ravel() for p in zip(lat, lon, h)])
    np.testing.assert_allclose(got, geodetic_to_ecef(lat, lon, h, earth=earth), rtol=0,
                               atol=ATOL_ECEF_M)


def test_symbolic_C_n_e_matches_the_numpy_owner(rng):
    lat, lon, _ = _points(rng)
    s_lat, s_lon = ca.SX.sym("lat"), ca.SX.sym("lon")
    fun = ca.Function("cne", [s_lat, s_lon], [C_n_e_sx(s_lat, s_lon)])
    for a, b in zip(lat, lon):
        np.testing.assert_allclose(np.array(fun(a, b)), C_n_e(a, b), rtol=0,
                                   atol=ATOL_ROTATION)


def _satellites(r_e, up_e, rng, n=7):
    """Satellites ~20 000 km away above the receiver, the last two Galileo."""
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    dirs = np.where((dirs @ up_e)[:, None] > 0.2, dirs, -dirs)
    z = np.zeros(n)
    return PreparedEpoch(
        gps_time_s=0.0, sv=np.array([f"X{i:02d}" for i in range(n)], dtype=object),
        system=np.array(["G"] * (n - 2) + ["E"] * 2, dtype=object),
        sat_pos_e=r_e + 2.02e7 * dirs, sat_vel_e=rng.normal(scale=2000.0, size=(n, 3)),
        sat_clock_m=rng.normal(scale=1e4, size=n), sat_clock_drift_mps=rng.normal(size=n),
        iono_m=rng.uniform(1, 10, n), tropo_m=rng.uniform(2, 20, n), elevation=z, azimuth=z,
        pseudorange_m=z, range_rate_mps=z, cn0_dbhz=z, sigma_pr_m=z + 1, sigma_rr_mps=z + 1)


def _reference(layout, prep, x, earth):
    """Pseudorange and range rate composed in NumPy through `gnss_obs.observables`."""
    lat, lon, h = (x[layout.index(n)] for n in ("lat", "lon", "h"))
    v_n = np.array([x[layout.index(n)] for n in ("v_E", "v_N", "v_U")])
    r_e = geodetic_to_ecef(lat, lon, h, earth=earth)
    b_sat = x[layout.index("clock_bias")] + np.where(prep.system == "E",
                                                     x[layout.index("isb_E")], 0.0)
    rho, _, _ = predict_pseudorange(prep, r_e=r_e, b_m=b_sat)
    rate, _, _, _ = predict_range_rate(prep, r_e=r_e, v_e=C_n_e(lat, lon) @ v_n,
                                       d_mps=x[layout.index("clock_drift")])
    return rho, rate


@pytest.mark.parametrize("earth", [WGS84, sphere()], ids=["wgs84", "sphere"])
@pytest.mark.parametrize("lat_deg, lon_deg", [(41.39, 2.17), (-33.9, 151.2), (0.0, 179.9),
                                              (78.2, 15.6)])
def test_rows_equal_the_observables_at_the_geodetic_receiver(earth, rng, lat_deg, lon_deg):
    model = build_unconstrained_model(earth, estimate_biases=True, isb_systems=("E",))
    layout = model.layout
    rows = build_geodetic_rows(layout, ("isb_E",), earth=earth)
    x = np.zeros(layout.size)
    values = {"lat": np.radians(lat_deg), "lon": np.radians(lon_deg), "h": 250.0,
              "v_E": 17.0, "v_N": -9.5, "v_U": 0.3, "clock_bias": 1234.5,
              "clock_drift": -0.7, "isb_E": 8.25, "yaw": 0.3, "b_ax": 0.01}
    for name, value in values.items():
        x[layout.index(name)] = value
    r_e = geodetic_to_ecef(values["lat"], values["lon"], values["h"], earth=earth)
    prep = _satellites(r_e, C_n_e(values["lat"], values["lon"])[:, 2], rng)
    rho, H_pr = rows.pseudorange.evaluate(x, pseudorange_parameters(np.zeros(0), prep, ("E",)))
    rate, H_rr = rows.range_rate.evaluate(x, range_rate_parameters(np.zeros(0), prep))
    rho_ref, rate_ref = _reference(layout, prep, x, earth)
    np.testing.assert_allclose(rho, rho_ref, rtol=0, atol=ATOL_RANGE_M)
    np.testing.assert_allclose(rate, rate_ref, rtol=0, atol=ATOL_RATE_MPS)
    for name, step in STEP.items():
        i = layout.index(name)
        dx = np.zeros(layout.size)
        dx[i] = step
        up, down = _reference(layout, prep, x + dx, earth), _reference(layout, prep, x - dx,
                                                                       earth)
        for H, k in ((H_pr, 0), (H_rr, 1)):
            rounding = 10 * np.finfo(float).eps * RANGE_SCALE_M / (2 * step)
            np.testing.assert_allclose(H[:, i], (up[k] - down[k]) / (2 * step),
                                       rtol=RTOL_JACOBIAN, atol=rounding, err_msg=name)
    # attitude and IMU biases do not enter GNSS (no lever arm)
    others = [layout.index(n) for n in layout.names if n not in STEP]
    assert not H_pr[:, others].any() and not H_rr[:, others].any()
