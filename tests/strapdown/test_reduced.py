"""The track-constrained model: Jacobians vs central differences (also w.r.t. s through the
track linearization), zero rates and zero pseudo-observation for a stationary vehicle,
the cross-track basis on an azimuth/grade edge table, consistency with the full model."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from types import SimpleNamespace

from strapdown.euler import C_b_n
from strapdown.frames import omega_ie_n, radii_of_curvature
from strapdown.gravity import g_n
from strapdown.kinematics import SensorBiasStates
from strapdown.mechanization import build_full_model
from strapdown.reduced import build_reduced_model, cross_track_basis, track_parameters
from trackmodel.earth import WGS84, sphere


# Central differences (conftest.FD_STEP = 1e-6 relative): truncation ~1e-12 relative,
# rounding 1e-16 |f| / 1e-6 with |f| up to ~1e4 (s): 1e-6 relative / 1e-8 absolute.
RTOL_JAC = 1e-6
ATOL_JAC = 1e-8
ATOL_UNIT = 1e-15
ATOL_STATIONARY = 1e-13      # m/s², rad/s: exact cancellation


def curved_point(rng, azimuth=None, elevation=None):
    """A TrackPoint-like namespace with a consistent tangent and curvature (1/m)."""
    A = rng.uniform(0, 2 * np.pi) if azimuth is None else azimuth
    th = rng.uniform(-0.05, 0.05) if elevation is None else elevation
    u = np.array([np.cos(th) * np.sin(A), np.cos(th) * np.cos(A), np.sin(th)])
    kappa, dtheta = rng.uniform(-2e-3, 2e-3), rng.uniform(-1e-4, 1e-4)
    du = kappa * np.array([np.cos(th) * np.cos(A), -np.cos(th) * np.sin(A), 0]) + dtheta * np.array(
        [-np.sin(th) * np.sin(A), -np.sin(th) * np.cos(A), np.cos(th)])
    return SimpleNamespace(s=np.array([rng.uniform(0, 1e4)]), lat=np.array([rng.uniform(-1.3, 1.3)]),
                           lon=np.array([rng.uniform(-3, 3)]), h=np.array([rng.uniform(0, 800)]),
                           u_n=u[None], du_ds_n=du[None], d2u_ds2_n=rng.normal(0, 1e-6, (1, 3)))


@pytest.mark.parametrize("biases", [None, SensorBiasStates(gyro_tau_s=500.0)])
def test_jacobians_match_central_differences(rng, biases, central_jacobian):
    model = build_reduced_model(WGS84, biases)
    for _ in range(5):
        pt = curved_point(rng)
        p = track_parameters(pt)[0]
        x = np.concatenate([[rng.uniform(0, 6), rng.uniform(-0.05, 0.05),
                             rng.uniform(-0.05, 0.05), p[0] + rng.uniform(-5, 5), rng.uniform(-30, 30)],
                            rng.normal(0, 1e-3, 6 if biases else 0)])
        u = np.concatenate([rng.normal(0, 1, 3) + [0, 0, 9.8], rng.normal(0, 0.05, 3)])
        for fn, jac_x, jac_u in ((model.f, model.F_x, model.G), (model.h_c, model.H_x, model.D)):
            np.testing.assert_allclose(np.asarray(jac_x(x, u, p)),
                                       central_jacobian(lambda xx: fn(xx, u, p), x),
                                       rtol=RTOL_JAC, atol=ATOL_JAC)
            np.testing.assert_allclose(np.asarray(jac_u(x, u, p)),
                                       central_jacobian(lambda uu: fn(x, uu, p), u),
                                       rtol=RTOL_JAC, atol=ATOL_JAC)


@pytest.mark.parametrize("earth", [WGS84, sphere()])
def test_stationary_vehicle_on_track(rng, earth):
    model = build_reduced_model(earth)
    for _ in range(10):
        pt = curved_point(rng)
        p = track_parameters(pt, earth=earth)[0]
        yaw, pitch = np.arctan2(pt.u_n[0, 0], pt.u_n[0, 1]), np.arcsin(pt.u_n[0, 2])
        roll = rng.uniform(-0.1, 0.1)
        C = C_b_n(yaw, pitch, roll)
        lat, h = pt.lat[0], pt.h[0]
        u = np.concatenate([-C.T @ g_n(lat, h, earth=earth), C.T @ omega_ie_n(lat, earth=earth)])
        x = np.array([yaw, pitch, roll, pt.s[0], 0.0])
        np.testing.assert_allclose(np.asarray(model.f(x, u, p)).ravel(), 0.0, atol=ATOL_STATIONARY)
        np.testing.assert_allclose(np.asarray(model.h_c(x, u, p)).ravel(), 0.0, atol=ATOL_STATIONARY)


@pytest.mark.parametrize("azimuth_deg", [0.0, 90.0, 180.0, 270.0, 33.0])
@pytest.mark.parametrize("elevation_deg", [0.0, 3.0, -30.0, 80.0])
def test_cross_track_basis_edge_table(azimuth_deg, elevation_deg):
    A, th = np.radians(azimuth_deg), np.radians(elevation_deg)
    u = np.array([np.cos(th) * np.sin(A), np.cos(th) * np.cos(A), np.sin(th)])
    sym = ca.SX.sym("u", 3)
    fn = ca.Function("basis", [sym], [ca.horzcat(sym / ca.norm_2(sym), *cross_track_basis(sym))])
    basis = np.asarray(fn(u))
    np.testing.assert_allclose(basis.T @ basis, np.eye(3), atol=ATOL_UNIT)
    # With zero roll the basis is the body frame (columns of C_b_n(A, ϑ, 0)).
    np.testing.assert_allclose(basis, C_b_n(A, th, 0.0), atol=ATOL_UNIT)


def test_reduced_agrees_with_full_model_on_track(rng):
    """v̇ = uᵀ(dv_n/dt of the full model) and h_c = P⊥(dv_n/dt − v² du/ds)."""
    reduced, full = build_reduced_model(WGS84), build_full_model(WGS84)
    for _ in range(10):
        pt = curved_point(rng)
        p = track_parameters(pt)[0]
        v = rng.uniform(-30, 30)
        x_r = np.array([rng.uniform(0, 6), rng.uniform(-.05, .05), rng.uniform(-.05, .05), pt.s[0], v])
        x_f = np.concatenate([x_r[:3], v * pt.u_n[0], [pt.lat[0], pt.lon[0], pt.h[0]]])
        u = np.concatenate([rng.normal(0, 1, 3) + [0, 0, 9.8], rng.normal(0, 0.05, 3)])
        dr, df = np.asarray(reduced.f(x_r, u, p)).ravel(), np.asarray(full.f(x_f, u)).ravel()
        np.testing.assert_allclose(dr[:3], df[:3], atol=1e-15)
        assert dr[4] == pytest.approx(pt.u_n[0] @ df[3:6], abs=1e-13)
        C = C_b_n(np.arctan2(pt.u_n[0, 0], pt.u_n[0, 1]), np.arcsin(pt.u_n[0, 2]), 0.0)
        resid = C[:, 1:].T @ (df[3:6] - v * v * pt.du_ds_n[0])
        np.testing.assert_allclose(np.asarray(reduced.h_c(x_r, u, p)).ravel(), resid, atol=1e-13)


def test_track_parameters_rates_of_position():
    pt = curved_point(np.random.default_rng(1), azimuth=np.radians(30), elevation=0.05)
    p = track_parameters(pt, earth=WGS84)[0]
    R_M, R_N = radii_of_curvature(pt.lat[0])
    assert p[4] == pytest.approx(pt.u_n[0, 1] / (R_M + pt.h[0]), rel=1e-15)
    assert p[5] == pytest.approx(pt.u_n[0, 0] / ((R_N + pt.h[0]) * np.cos(pt.lat[0])), rel=1e-15)
    assert p[6] == pytest.approx(np.sin(0.05), rel=1e-15)
