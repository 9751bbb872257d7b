"""The gnss-only filter's Huber weight on an epoch's heading angle
(`railnav.filters.gnss_only_noise.robust_heading_sigma_rad`,
``NavigatorConfig.track_heading_huber_k``).

Independent checks: an epoch simulated with the antenna's velocity rotated off the track's
tangent by a known angle ψ (`gnss_obs.simulate.simulate_gnss`, through the range-rate
observable itself, no linearisation) gives back ψ from the filter's range-rate
innovations; Huber's weight (Huber 1964) makes the angle enter at ``√(k r)`` σ."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.simulate import GnssSimConfig, default_nav_path, simulate_gnss
from railnav.config import NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.gnss_epochs import GnssEpochs
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.filters.gnss_only_noise import _heading_projections, robust_heading_sigma_rad
from railnav.filters.track_frame import track_axes_n
from railnav.simulation.scenarios import DEFAULT_START_GPS_TIME_S, TRACKS_DIR, Scenario
from railnav.simulation.profiles import constant_speed
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import C_n_e
from trackmodel.io import read_track

#: curvy.csv at 9540 m: an arc of R 600 m.
S_M, SPEED_MPS = 9540.0, 12.0
#: Range-rate noise of the simulated epoch, m/s: small, so that ψ comes back to
#: σ_rr / (|v| √n) ~ 1e-5 rad besides the second-order terms of a rotation (ψ³/6).
SIGMA_RR_MPS = 1e-4
SIGMA_PSI_RAD = 0.03


def _epoch(psi_rad: float):
    """The range-rate rows, innovations and Jacobian at the true state of one epoch whose
    velocity is ``v (t cos ψ + n sin ψ)``; the prior's speed and clock unknown (σ 1 km/s),
    its ``s`` known (σ 1e-6 m: no angle from the curvature)."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    sc = Scenario(name="t", profile=constant_speed(SPEED_MPS), duration_s=10.0,
                  sigma_pseudorange_m=3.0, sigma_range_rate_mps=SIGMA_RR_MPS)
    config = navigator_config_for(sc, filter="gnss-only", systems="G")
    point = track.at(np.array([S_M, S_M]))
    one = type(point)(**{f: getattr(point, f)[0] for f in point.__dataclass_fields__})
    axes = track_axes_n(one)
    C = C_n_e(float(point.lat[0]), float(point.lon[0]))
    t_e, n_e = C @ axes["along"], C @ axes["left"]
    v_e = SPEED_MPS * (math.cos(psi_rad) * t_e + math.sin(psi_rad) * n_e)
    nav = read_rinex_nav(default_nav_path())
    sim = simulate_gnss(DEFAULT_START_GPS_TIME_S + np.array([0.0, 1.0]), point.r_e,
                        np.tile(v_e, (2, 1)), nav,
                        GnssSimConfig(systems="G", sigma_pr_m=3.0, sigma_rr_mps=SIGMA_RR_MPS),
                        rng=np.random.default_rng(0))
    gnss = GnssEpochs.from_files(sim.obs, nav, config.measurement,
                                 start_gps_time_s=DEFAULT_START_GPS_TIME_S, end_s=1.0)
    filt = GnssOnlyFilter(track, config, gnss)
    lay = filt.layout
    x = np.zeros(lay.size)
    x[lay.index("s")], x[lay.index("v")] = S_M, SPEED_MPS
    x[lay.index("clock_bias")] = float(sim.clock["clock_bias_m"].iloc[0])
    P = np.diag([1e-12 if n == "s" else 1e6 for n in lay.names])
    rr = [o for o in filt.observations(0, x, P) if o.model is filt.rows.rows.range_rate][0]
    z_pred, H = rr.model.evaluate(x, rr.p)
    return rr.z.reshape(-1) - z_pred, H, P, rr.R, rr.p


def _angle(innovation, H, P, R, p) -> tuple[float, float]:
    """ψ̂ and its variance without the heading's, by generalised least squares."""
    g = SPEED_MPS * _heading_projections(p)
    w = np.linalg.solve(H @ P @ H.T + np.diag(R), g)
    return float(w @ innovation) / float(g @ w), 1.0 / float(g @ w)


@pytest.mark.parametrize("psi_rad", [0.05, -0.2])
def test_the_angle_of_a_rotated_velocity_comes_back(psi_rad):
    """ψ̂ from the innovations equals the simulated rotation: sin ψ (the rows are linear
    in the velocity, whose normal component is v sin ψ; its along-track part,
    v (cos ψ − 1), goes to the unknown speed) within 1e-3 relative (the range-rate
    noise: σ_rr / (|v| √n) ~ 1e-5 rad). Its sign is the rows' (the range rate falls as
    the receiver moves towards a satellite); the weight takes |ψ̂|."""
    psi_hat, var0 = _angle(*_epoch(psi_rad))
    assert math.sqrt(var0) < 1e-4
    assert abs(psi_hat) == pytest.approx(abs(math.sin(psi_rad)), rel=1e-3)


@pytest.mark.parametrize("k", [1.5, 4.0])
def test_a_large_angle_enters_at_root_k_r(k):
    """Huber's weight: an angle of r σ (r > k) enters the update at √(k r) σ, i.e. its
    variance becomes ψ̂² / (k r); an angle within k σ keeps σ_ψ."""
    epoch = _epoch(-0.2)
    psi_hat, var0 = _angle(*epoch)
    r = abs(psi_hat) / math.sqrt(SIGMA_PSI_RAD ** 2 + var0)
    assert r > k
    sigma = robust_heading_sigma_rad(*epoch, SPEED_MPS, SIGMA_PSI_RAD, k)
    assert sigma ** 2 + var0 == pytest.approx(psi_hat ** 2 / (k * r), rel=1e-9)
    small = _epoch(0.5 * k * SIGMA_PSI_RAD)
    assert robust_heading_sigma_rad(*small, SPEED_MPS, SIGMA_PSI_RAD, k) == SIGMA_PSI_RAD


@pytest.mark.parametrize("k", [0.0, -1.0, math.nan, "4"])
def test_a_bad_threshold_is_a_config_error(k):
    with pytest.raises(ConfigError, match="track_heading_huber_k"):
        NavigatorConfig(track_heading_huber_k=k)
