"""GNSS fix rows (`railnav.filters.fix_rows`): Jacobians against central differences, the
row values against the track queried directly (`Track.at`, `Track.project`), the fault
screen on fixes off the track, the epoch schedule and the fix epochs."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gnss_obs.fixes.table import FIX_COLUMNS
from railnav.config import NavigatorConfig
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.fault_detection import RowScreen
from railnav.filters.fix_epochs import EpochSchedule, FixEpochs, FixModelConfig
from railnav.filters.fix_rows import (
    FixRowBuilder,
    build_fix_rows,
    stack_epoch_rows,
    track_axes_n,
)
from railnav.filters.gnss_only_model import build_gnss_only_model
from railnav.filters.gnss_rows import track_rows
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.io import read_track

CURVY = read_track(TRACKS_DIR / "curvy.csv")
#: s in a clothoid of curvy.csv (entry at 4300 m, 120 m long) and on its 2 % grade.
S_CLOTHOID_M = 4350.0
#: Central differences of a cubic in s (step 1e-3 m): truncation h²/6·|h'''| < 1e-9
#: relative; rounding ~ 1e-16·|r_e| / h ~ 1e-6 in units of the row per metre.
ATOL_JACOBIAN = 1e-5
#: The third-order expansion against Track.at within 10 m of s_ref (goal: 1 mm; its
#: remainder δ⁴|dκ/ds|·… is far below it on a clothoid).
ATOL_EXPANSION_M = 1e-3
LAYOUT = build_gnss_only_model((), clock=False).layout


def _fix_table(lat_deg, lon_deg, h_m, *, sigma_h=0.5, sigma_v=1.0, speed=np.nan,
               course=np.nan, t0=1e9, quality="dgps") -> pd.DataFrame:
    n = np.size(lat_deg)
    cols = {c: np.full(n, np.nan) for c in FIX_COLUMNS}
    cols.update(gps_time_s=t0 + np.arange(n, dtype=float), lat_deg=lat_deg, lon_deg=lon_deg,
                h_m=h_m, sigma_east_m=sigma_h, sigma_north_m=sigma_h, sigma_up_m=sigma_v,
                cov_en_m2=0.0, sigma_speed_mps=0.05, speed_mps=speed, course_deg=course,
                quality=np.full(n, quality, dtype=object), flag="", timestamp="",
                sigma_source="file")
    return pd.DataFrame(cols)[list(FIX_COLUMNS)]


def _fixes_at(r_e: np.ndarray, **kw) -> FixEpochs:
    lat, lon, h = ecef_to_geodetic(np.atleast_2d(r_e), earth=CURVY.earth)
    table = _fix_table(np.degrees(lat), np.degrees(lon), h, **kw)
    return FixEpochs.from_table(table, start_gps_time_s=1e9)


def test_jacobians_against_central_differences(rng):
    rows = build_fix_rows(LAYOUT)
    point = CURVY.at(S_CLOTHOID_M)
    part = track_rows(point, earth=CURVY.earth)
    for model in (rows.position, rows.speed):
        for _ in range(5):
            axis = rng.standard_normal(3)
            p = np.concatenate([part, axis / np.linalg.norm(axis)])[None, :]
            x = np.array([S_CLOTHOID_M + rng.uniform(-5, 5), rng.uniform(-30, 30)])
            _, H = model.evaluate(x, p)
            fd = np.zeros(2)
            for i, step in enumerate((1e-3, 1e-3)):
                dx = np.zeros(2)
                dx[i] = step
                fd[i] = (model.evaluate(x + dx, p)[0][0] - model.evaluate(x - dx, p)[0][0]) \
                    / (2 * step)
            np.testing.assert_allclose(H[0], fd, rtol=0, atol=ATOL_JACOBIAN)


def test_rows_follow_the_track_queried_directly():
    """h(s) = aᵀ C_e_n (r_e(s) − r_ref) and the speed row v aᵀ C_e_n t_e(s), with r_e and
    t_e from Track.at, within 10 m of the reference point."""
    rows = build_fix_rows(LAYOUT)
    ref = CURVY.at(S_CLOTHOID_M)
    C = C_n_e(ref.lat, ref.lon)
    part = track_rows(ref, earth=CURVY.earth)
    for name, a_n in track_axes_n(ref).items():
        p = np.concatenate([part, C @ a_n])[None, :]
        for delta in (-10.0, -3.0, 4.0, 10.0):
            q = CURVY.at(S_CLOTHOID_M + delta)
            z, _ = rows.position.evaluate(np.array([q.s, 0.0]), p)
            assert z[0] == pytest.approx(a_n @ C.T @ (q.r_e - ref.r_e), abs=ATOL_EXPANSION_M)
            v, _ = rows.speed.evaluate(np.array([q.s, 12.0]), p)
            t_e = C_n_e(q.lat, q.lon) @ q.u_n
            assert v[0] == pytest.approx(12.0 * (C @ a_n) @ t_e, abs=12.0 * ATOL_EXPANSION_M
                                         / 10.0), name


def test_fix_on_the_track_gives_its_distance_along():
    """A fix exactly on the track 3 m ahead of the prior: z is the chord on each axis
    (from Track.at directly): along ≈ 3 m, across κδ²/2 ≈ 1.6 mm in the clothoid; and
    the row's prediction at the fix's own s (Track.project, a second method) matches z."""
    q = CURVY.at(S_CLOTHOID_M + 3.0)
    ref = CURVY.at(S_CLOTHOID_M)
    builder = FixRowBuilder(CURVY, LAYOUT, _fixes_at(q.r_e), FixModelConfig())
    obs, sv, kind = builder.observations(0, np.array([S_CLOTHOID_M, 20.0]))
    d_n = C_n_e(ref.lat, ref.lon).T @ (q.r_e - ref.r_e)
    axes = track_axes_n(ref)
    z = dict(zip(kind, obs[0].z[:, 0]))
    for name, axis in (("fix_along", "along"), ("fix_cross", "cross"), ("fix_up", "up")):
        assert z[name] == pytest.approx(axes[axis] @ d_n, abs=1e-6)   # µm: geodetic round trip
    assert z["fix_along"] == pytest.approx(3.0, abs=ATOL_EXPANSION_M)
    lat, lon, h = ecef_to_geodetic(q.r_e[None, :], earth=CURVY.earth)
    s_fix = CURVY.project(lat, lon, h).s[0]
    pred, _ = obs[0].model.evaluate(np.array([s_fix, 20.0]), obs[0].p)
    np.testing.assert_allclose(pred, obs[0].z[:, 0], rtol=0, atol=ATOL_EXPANSION_M)
    assert list(sv) == ["fix:dgps"] * 3
    # R: the fix covariance on the axis (the 2 % grade tilts along and up), plus the
    # track's σ across and up (FixModelConfig)
    cfg = FixModelConfig()
    cov = np.diag([0.25, 0.25, 1.0])
    expected = [axes[a] @ cov @ axes[a] for a in ("along", "cross", "up")]
    expected[1] += cfg.track_cross_sigma_m ** 2
    expected[2] += cfg.track_vertical_sigma_m ** 2
    np.testing.assert_allclose(obs[0].R, expected, rtol=1e-12)
    assert expected[0] != pytest.approx(0.25, rel=1e-6)    # the grade is there


def test_speed_row_from_speed_and_course():
    """Speed 20 m/s along the track's azimuth: z = 20 (horizontal axis, no v_up)."""
    point = CURVY.at(S_CLOTHOID_M)
    fixes = _fixes_at(point.r_e, speed=20.0, course=np.degrees(point.azimuth))
    builder = FixRowBuilder(CURVY, LAYOUT, fixes, FixModelConfig())
    obs, _, kind = builder.observations(0, np.array([S_CLOTHOID_M, 19.0]))
    assert list(kind) == ["fix_along", "fix_cross", "fix_up", "fix_speed"]
    assert obs[1].z[0, 0] == pytest.approx(20.0, abs=1e-9)
    assert obs[1].R[0] == pytest.approx(0.05 ** 2)


@pytest.mark.parametrize("offset, axis", [(200.0, "cross"), (200.0, "along"), (0.5, "cross")])
def test_fault_screen_rejects_a_fix_far_off_as_a_whole(offset, axis):
    """A fix 200 m across (or along) the track from the prior is rejected, every row of
    it; one 0.5 m across is used. Prior σ_s 1 m, fix σ 0.5 m: along, S = 1.25 m² puts
    200 m at 180σ; across, only the cross row sees it, and the group rule takes the
    along row with it."""
    point = CURVY.at(S_CLOTHOID_M)
    a = track_axes_n(point)[axis]
    r_fix = point.r_e + C_n_e(point.lat, point.lon) @ (offset * a)
    builder = FixRowBuilder(CURVY, LAYOUT, _fixes_at(r_fix), FixModelConfig())
    x, P = np.array([S_CLOTHOID_M, 20.0]), np.diag([1.0, 0.25])
    obs, sv, kind, modes, groups = stack_epoch_rows(
        None, builder.observations(0, x), gnss_mode="channel", fix_group=0)
    screen = RowScreen(FaultDetectionConfig())
    used = screen.screen(obs, sv, kind, x, P, modes=modes, groups=groups)
    status = screen.last.status
    if offset > 100:
        assert used == [] and set(status) == {"rejected"}
    else:
        assert set(status) == {"used"} and sum(o.rows for o in used) == 3


def test_epoch_schedule_merges_on_time():
    sched = EpochSchedule.merge([0.0, 1.0, 2.0], [0.4, 1.0, 1.0 + 5e-7, 2.8], tol_s=1e-6)
    np.testing.assert_allclose(sched.time_s, [0.0, 0.4, 1.0, 2.0, 2.8])
    assert sched.gnss_index.tolist() == [0, -1, 1, 2, -1]
    # two fixes within the tolerance of one GNSS epoch: the later one is that epoch's
    assert sched.fix_index.tolist() == [-1, 0, 2, -1, 3]
    assert sched.split(2) == (1, 2)


def test_fix_epochs_cut_outages_and_build_velocity():
    table = _fix_table([48.1, 48.1, 48.1], [11.5, 11.5, 11.5], [np.nan] * 3, speed=10.0,
                       course=30.0)
    fixes = FixEpochs.from_table(table, start_gps_time_s=1e9, outages=[(0.5, 1.0)])
    np.testing.assert_allclose(fixes.time_s, [0.0, 2.0])
    np.testing.assert_allclose(fixes.v_n_mps[0, :2], [10 * np.sin(np.radians(30)),
                                                      10 * np.cos(np.radians(30))])
    assert np.isnan(fixes.v_n_mps[0, 2]) and np.isnan(fixes.h_m).all()


def test_fix_model_config_is_checked():
    with pytest.raises(ValueError, match="track_cross_sigma_m"):
        FixModelConfig(track_cross_sigma_m=-1.0)
    with pytest.raises(ValueError, match="fix_model"):
        NavigatorConfig(fix_model="no")
