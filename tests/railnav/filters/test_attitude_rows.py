"""Attitude and standstill rows (`railnav.filters.attitude_rows`, `standstill_rows`).

References: each CasADi Jacobian against central differences of its own h; the residuals
against closed forms (a body whose attitude is the chord's and mounting's exactly gives 0; a
small yaw offset shows as itself; the zero-rate row of a gyro reading exactly the Earth rate
plus the bias is 0).
"""
from __future__ import annotations

import numpy as np
import pytest

from ekf.layout import StateLayout
from railnav.errors import ConfigError
from railnav.filters.attitude_config import MOUNT_STATES, TrackAttitudeConfig
from railnav.filters.attitude_rows import AttitudeRowBuilder, build_attitude_rows
from railnav.filters.car_body import chord_offsets
from railnav.filters.standstill_rows import build_zero_rate_rows, build_zero_speed_rows
from strapdown.euler import C_b_n, euler_from_C_b_n, relative_dcm
from strapdown.frames import omega_ie_n

LAYOUT = StateLayout.from_blocks([("attitude", ("yaw", "pitch", "roll")), ("s", 1), ("v", 1),
                                  ("gyro_bias", ("b_gx", "b_gy", "b_gz")),
                                  ("mount", MOUNT_STATES)])
#: Central differences with h = 1e-6 of smooth functions of O(1): truncation ~1e-12,
#: rounding ~1e-10.
ATOL_JACOBIAN = 1e-7


def _fd_jacobian(model, x, p):
    h = 1e-6
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((model.evaluate(x + e, p)[0] - model.evaluate(x - e, p)[0]) / (2 * h))
    return np.column_stack(cols)


@pytest.fixture(scope="module")
def track(curve_onset_track):
    return curve_onset_track      # tests/railnav/filters/conftest.py


def _state(rng, yaw=0.1):
    x = np.zeros(LAYOUT.size)
    x[LAYOUT.slice("attitude")] = [yaw, 0.01, -0.02]
    x[LAYOUT.index("s")], x[LAYOUT.index("v")] = 300.0, 12.0
    x[LAYOUT.slice("gyro_bias")] = rng.normal(0, 1e-4, 3)
    x[LAYOUT.slice("mount")] = rng.normal(0, 0.02, 3)
    return x


def test_attitude_jacobian_matches_finite_differences(track, rng):
    builder = AttitudeRowBuilder(LAYOUT, track, TrackAttitudeConfig())
    x = _state(rng)
    (obs,), _, _ = builder.observations(0, x, np.eye(LAYOUT.size))
    z, H = obs.model.evaluate(x, obs.p)
    np.testing.assert_allclose(H, _fd_jacobian(obs.model, x, obs.p), atol=ATOL_JACOBIAN)
    assert np.abs(H[0, LAYOUT.index("s")]) > 0      # ∂h_yaw/∂s: the track's curvature


def test_true_body_on_its_chord_gives_zero_residuals(track, rng):
    """IMU attitude = chord attitude turned by the mounting: h = 0 (to the linearization
    about s₀ = s, exact); a yaw offset of the body by ε shows as ε."""
    cfg = TrackAttitudeConfig()
    s = 420.0
    pt = track.at(s)
    c = chord_offsets(track, [s], bogie_spacing_m=cfg.bogie_spacing_m,
                      imu_offset_m=cfg.imu_offset_m)
    mount = np.array([0.015, -0.01, 0.02])
    for eps in (0.0, 2e-3):
        body = C_b_n(float(pt.azimuth + c.yaw[0] + eps), float(pt.elevation + c.pitch[0]), 0.0)
        yaw, pitch, roll = euler_from_C_b_n(body @ relative_dcm(*mount))
        x = np.zeros(LAYOUT.size)
        x[LAYOUT.slice("attitude")] = [yaw, pitch, roll]
        x[LAYOUT.index("s")] = s
        x[LAYOUT.slice("mount")] = mount
        (obs,), sv, kind = AttitudeRowBuilder(LAYOUT, track, cfg).observations(0, x, None)
        z, _ = obs.model.evaluate(x, obs.p)
        np.testing.assert_allclose(z, [eps, 0.0, 0.0], atol=1e-12)
    assert list(kind) == ["att_yaw", "att_pitch", "att_roll"]


def test_relative_dcm_composes_like_the_euler_angles():
    """C_b_n(ψ₁,0,0) M(ψ₂,0,0) = C_b_n(ψ₁+ψ₂,0,0); M(0,0,0) = I; small angles add to first
    order (a second method: the DCM's own Euler angles)."""
    np.testing.assert_allclose(relative_dcm(0.0, 0.0, 0.0), np.eye(3), atol=1e-15)
    np.testing.assert_allclose(C_b_n(0.4, 0.0, 0.0) @ relative_dcm(0.1, 0.0, 0.0),
                               C_b_n(0.5, 0.0, 0.0), atol=1e-15)
    yaw, pitch, roll = euler_from_C_b_n(C_b_n(0.4, 0.01, 0.0) @ relative_dcm(0.0, 0.02, 0.03))
    np.testing.assert_allclose([yaw, pitch, roll], [0.4, 0.03, 0.03], atol=1e-3)
    M = relative_dcm(0.3, -0.2, 0.1)
    np.testing.assert_allclose(M @ M.T, np.eye(3), atol=1e-15)


def test_yaw_row_wraps_across_north(track):
    """Azimuth 350° and a body at 10° − 20°·(−1): residual of a 1° offset across north."""
    model = build_attitude_rows(LAYOUT)
    x = np.zeros(LAYOUT.size)
    x[LAYOUT.index("yaw")] = np.radians(0.5)
    p = np.zeros((1, 12))
    p[0, 0], p[0, 3] = 1.0, np.radians(359.5)
    z, _ = model.evaluate(x, p)
    assert z[0] == pytest.approx(np.radians(1.0), abs=1e-12)


def test_standstill_rows(rng):
    x = _state(rng)
    speed = build_zero_speed_rows(LAYOUT)
    z, H = speed.evaluate(x, np.zeros((1, 1)))
    assert z[0] == x[LAYOUT.index("v")] and H[0, LAYOUT.index("v")] == 1.0
    rate = build_zero_rate_rows(LAYOUT)
    C = C_b_n(*x[LAYOUT.slice("attitude")])
    normal = C_b_n(0.3, 0.01, 0.0)[:, 2]
    earth = np.asarray(omega_ie_n(np.radians(47.0)))
    still_gyro = C.T @ earth + x[LAYOUT.slice("gyro_bias")]          # a still IMU's reading
    p = np.concatenate([still_gyro, normal, earth])[None, :]
    z, H = rate.evaluate(x, p)
    assert z[0] == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(H, _fd_jacobian(rate, x, p), atol=ATOL_JACOBIAN)
    turning = p.copy()
    turning[0, :3] += 1e-3 * (C.T @ normal)                          # 1 mrad/s about the normal
    assert rate.evaluate(x, turning)[0][0] == pytest.approx(1e-3, rel=1e-9)


@pytest.mark.parametrize("bad", [dict(sigma_rad=(1e-3, 0.0, 1e-3)), dict(interval_s=-1.0),
                                 dict(imu_offset_m=30.0), dict(mount_sigma_rad=float("inf"))])
def test_bad_attitude_config_is_refused(bad):
    with pytest.raises(ConfigError, match="track attitude"):
        TrackAttitudeConfig(**bad)


def test_no_pitch_row_where_the_grade_is_unknown(track, rng):
    """A network without heights (railnav.filters.grade_noise): the pitch row would hold
    the body to the level track's pitch. Without it the yaw and roll rows are those of the
    full builder (same residuals, variances with the same geometry noise added), and a
    navigator config with an unknown grade builds it so (railnav.filters.body_rows)."""
    from dataclasses import replace

    from railnav.config import NavigatorConfig
    from railnav.filters.body_rows import BodyRows
    x, P = _state(rng), np.diag(np.full(LAYOUT.size, 4.0))
    (full,), _, kinds = AttitudeRowBuilder(LAYOUT, track, TrackAttitudeConfig()).observations(
        0, x, P)
    (obs,), sv, kind = AttitudeRowBuilder(LAYOUT, track, TrackAttitudeConfig(),
                                          use_pitch=False).observations(0, x, P)
    assert list(kinds) == ["att_yaw", "att_pitch", "att_roll"]
    assert list(kind) == ["att_yaw", "att_roll"]
    np.testing.assert_array_equal(obs.model.evaluate(x, obs.p)[0],
                                  full.model.evaluate(x, full.p)[0][[0, 2]])
    np.testing.assert_array_equal(obs.R, full.R[[0, 2]])
    config = replace(NavigatorConfig(imu_errors="tactical",
                                     track_attitude=TrackAttitudeConfig()),
                     track_grade_sigma_rad=0.02)
    rows = BodyRows(LAYOUT, track, config, {"attitude": None})
    assert rows.builders["attitude"].axes == (0, 2)
    rows = BodyRows(LAYOUT, track, replace(config, track_grade_sigma_rad=None),
                    {"attitude": None})
    assert rows.builders["attitude"].axes == (0, 1, 2)
