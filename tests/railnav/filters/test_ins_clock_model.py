"""The inertial filters' shared model parts (railnav/filters/ins_clock_model.py) and the two models
built on them (railnav/filters/constrained_model.py, railnav/filters/unconstrained_model.py).

References: the noise densities written out from the IMU grade's datasheet values
(`strapdown.imu_errors.IMU_GRADES`: ``N²``, Gauss–Markov ``2σ²/τ``) and the oscillator
(`gnss_obs.oscillator`); ``G = −∂f/∂u`` against central differences of ``f``; the full
mechanization `strapdown.mechanization` for the navigation rows of ``f``.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from gnss_obs.measurements import MeasurementConfig
from gnss_obs.oscillator import oscillator_from_name
from railnav.config import NavigatorConfig
from railnav.filters.constrained_model import SCALE_ELEMENTS, build_constrained_model
from railnav.filters.ins_clock_model import ISB_RANDOM_WALK_M2PS
from railnav.filters.protocol import make_filter
from railnav.filters.unconstrained_model import build_unconstrained_model
from railnav.simulation.scenarios import TRACKS_DIR
from strapdown.imu_errors import IMU_GRADES
from strapdown.kinematics import scale_state_name
from strapdown.mechanization import build_full_model
from trackmodel.earth import WGS84
from trackmodel.io import read_track

#: Finite-difference step of the IMU input (m/s², rad/s) and the relative accuracy of a
#: central difference of a smooth function there (truncation ~step², rounding ~ε/step).
FD_STEP_U = 1e-5
RTOL_G = 1e-5
ATOL_G = 1e-9


@pytest.mark.parametrize("grade", ["tactical", "mems", "navigation", "paper2017"])
@pytest.mark.parametrize("isb", [(), ("E",)])
def test_noise_densities_are_the_grade_and_clock_values_for_both_models(grade, isb):
    imu, osc = IMU_GRADES[grade], oscillator_from_name("tcxo")
    biases = grade != "paper2017"
    expected = [imu.accel_noise_density_mps2_rthz ** 2] * 3 + \
        [imu.gyro_noise_density_radps_rthz ** 2] * 3
    if biases:
        expected += [2 * imu.accel_bias_instability_mps2 ** 2 / imu.accel_bias_tau_s] * 3
        expected += [2 * imu.gyro_bias_instability_radps ** 2 / imu.gyro_bias_tau_s] * 3
    expected += [osc.q_bias_m2ps, osc.q_drift_m2ps3] + [ISB_RANDOM_WALK_M2PS] * len(isb)
    for build in (build_constrained_model, build_unconstrained_model):
        model = build(WGS84, estimate_biases=biases, isb_systems=isb)
        q = model.process_noise_density(imu, osc)
        np.testing.assert_allclose(q, expected, rtol=1e-15, atol=0)
        assert model.process.n_w == len(expected) == len(model.noise_names)


def test_both_filters_assume_the_same_initial_variances_of_their_common_states():
    """Attitude, IMU biases, clock and ISB: the same σ (and the same noise densities) for
    the same configuration. The constrained filter alone carries elements of the IMU's
    ``S + M`` (`constrained_model.SCALE_ELEMENTS`): their prior is the grade's scale-factor
    σ on the diagonal and its misalignment σ off it (written out here), their noise
    negligible."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    config = NavigatorConfig(imu_errors="mems", measurement=MeasurementConfig(systems="GE"))
    covs, noise = {}, {}
    for kind in ("constrained", "unconstrained"):
        filt = make_filter(track, replace(config, filter=kind), None)
        P0 = filt.initial_covariance(sigma_s_m=5.0, sigma_v_mps=0.1)
        covs[kind] = dict(zip(filt.layout.names, np.diag(P0)))
        noise[kind] = dict(zip(filt.model.noise_names, filt.q_c))
    common = set(covs["constrained"]) & set(covs["unconstrained"])
    assert common == {"yaw", "pitch", "roll", "b_ax", "b_ay", "b_az", "b_gx", "b_gy", "b_gz",
                      "clock_bias", "clock_drift", "isb_E"}
    scale = {scale_state_name(sensor, element) for sensor, elements
             in zip("ag", SCALE_ELEMENTS) for element in elements}
    assert set(covs["constrained"]) - common == {"s", "v"} | scale
    shared_noise = set(noise["constrained"]) & set(noise["unconstrained"])
    assert set(noise["constrained"]) - shared_noise == {f"w_{n}" for n in scale}
    for name in shared_noise:
        assert noise["constrained"][name] == noise["unconstrained"][name]
    imu = IMU_GRADES["mems"]
    expected = {"yaw": config.initial_attitude_sigma_rad ** 2,
                "b_ax": imu.accel_bias_mps2 ** 2 + imu.accel_bias_instability_mps2 ** 2,
                "b_gz": imu.gyro_bias_radps ** 2 + imu.gyro_bias_instability_radps ** 2,
                "clock_bias": config.initial_clock_bias_sigma_m ** 2,
                "isb_E": config.initial_isb_sigma_m ** 2}
    for name in common:
        assert covs["constrained"][name] == covs["unconstrained"][name]
    for name, value in expected.items():
        assert covs["unconstrained"][name] == pytest.approx(value, rel=1e-15)
    for name in scale:                        # k_<sensor>_<row><column>
        sensor = "accel" if name[2] == "a" else "gyro"
        sigma = getattr(imu, f"{sensor}_scale_factor_ppm") * 1e-6 if name[4] == name[5] \
            else getattr(imu, f"{sensor}_misalignment_rad")
        assert covs["constrained"][name] == pytest.approx(sigma ** 2, rel=1e-15)
        assert noise["constrained"][f"w_{name}"] < 1e-20


def _fd_G(model, x, u, p):
    """−∂f/∂u by central differences, (n, 6)."""
    cols = []
    for k in range(6):
        du = np.zeros(6)
        du[k] = FD_STEP_U
        cols.append(-(np.array(model.process.f(x, u + du, p)) -
                      np.array(model.process.f(x, u - du, p))).ravel() / (2 * FD_STEP_U))
    return np.column_stack(cols)


@pytest.mark.parametrize("biases", [False, True])
def test_unconstrained_dynamics_are_the_full_mechanization_plus_clock(biases, rng):
    model = build_unconstrained_model(WGS84, estimate_biases=biases, isb_systems=("E",))
    layout = model.layout
    full = build_full_model(WGS84, None)
    x = np.zeros(layout.size)
    nav = {"yaw": 0.7, "pitch": 0.01, "roll": -0.02, "v_E": 12.0, "v_N": -20.0, "v_U": 0.2,
           "lat": math.radians(41.4), "lon": math.radians(2.2), "h": 120.0,
           "clock_bias": 300.0, "clock_drift": -1.5, "isb_E": 4.0}
    for name, value in nav.items():
        x[layout.index(name)] = value
    u = np.array([0.3, -0.1, 9.81, 1e-3, -2e-3, 0.05])
    if biases:
        b = rng.normal(scale=[1e-2, 1e-2, 1e-2, 1e-4, 1e-4, 1e-4])
        x[layout.slice("imu_bias")] = b
    else:
        b = np.zeros(6)
    p = np.zeros(0)
    xdot = np.array(model.process.f(x, u, p)).ravel()
    nav_names = ("yaw", "pitch", "roll", "v_E", "v_N", "v_U", "lat", "lon", "h")
    x_nav = np.array([x[layout.index(n)] for n in nav_names])
    # biases are subtracted from the measured input; bias, ISB rates 0; ḃ_clock = drift
    expected_nav = np.array(full.f(x_nav, u - b)).ravel()
    np.testing.assert_allclose([xdot[layout.index(n)] for n in nav_names], expected_nav,
                               rtol=1e-14, atol=1e-18)
    assert xdot[layout.index("clock_bias")] == nav["clock_drift"]
    others = [layout.index(n) for n in layout.names if n not in nav_names + ("clock_bias",)]
    assert not xdot[others].any()
    G = np.array(model.process.G(x, u, p))
    np.testing.assert_allclose(G[:, :6], _fd_G(model, x, u, p), rtol=RTOL_G, atol=ATOL_G)
    walk = [n.removeprefix("w_") for n in model.noise_names[6:]]
    np.testing.assert_array_equal(G[:, 6:], np.eye(layout.size)[:, [layout.index(n)
                                                                     for n in walk]])


def test_constrained_noise_map_and_pseudo_observation_noise_are_minus_input_derivatives():
    model = build_constrained_model(WGS84, estimate_biases=True)
    layout = model.layout
    x = np.zeros(layout.size)
    x[layout.index("yaw")], x[layout.index("s")], x[layout.index("v")] = 0.4, 100.0, 20.0
    u = np.array([0.2, 0.05, 9.8, 1e-4, 1e-3, 0.02])
    p = np.zeros(16)
    p[:4] = [100.0, math.radians(41.4), math.radians(2.2), 50.0]
    p[7:10] = [math.sin(0.4), math.cos(0.4), 0.0]
    np.testing.assert_allclose(np.array(model.process.G(x, u, p))[:, :6], _fd_G(model, x, u, p),
                               rtol=RTOL_G, atol=ATOL_G)
    D_fd = np.column_stack([
        -(np.array(model.process.h_c(x, u + FD_STEP_U * e, p)) -
          np.array(model.process.h_c(x, u - FD_STEP_U * e, p))).ravel() / (2 * FD_STEP_U)
        for e in np.eye(6)])
    D = np.array(model.process.D(x, u, p))
    np.testing.assert_allclose(D[:, :6], D_fd, rtol=RTOL_G, atol=ATOL_G)
    assert not D[:, 6:].any()


def test_an_ideal_imu_is_filtered_with_the_papers_white_noise():
    """The accelerometer observation needs a positive noise: a ``perfect`` IMU gets the
    2017 paper's densities (its preset) instead of zero."""
    paper, osc = IMU_GRADES["paper2017"], oscillator_from_name("tcxo")
    model = build_constrained_model(WGS84, estimate_biases=False, isb_systems=())
    q = model.process_noise_density(IMU_GRADES["perfect"], osc)
    np.testing.assert_array_equal(q[:6], [paper.accel_noise_density_mps2_rthz ** 2] * 3
                                  + [paper.gyro_noise_density_radps_rthz ** 2] * 3)
