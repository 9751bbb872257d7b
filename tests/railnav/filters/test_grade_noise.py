"""A grade the track does not know (`railnav.filters.grade_noise`): an IMU navigated on a
network without heights. References: a trip simulated by ``railnav simulate`` on the same
netelement with closed-form heights (a 1.2 % grade wave), its truth (``truth.csv``: the
body's pitch, lat/lon) and the truth's own projection on the level netelement
(`trackmodel.network.Network.project`) for the along-track error; the χ² law of
normalized errors (≤ 1 % beyond 3σ)."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from railnav.config import NavigatorConfig
from railnav.filters.grade_noise import (
    GRADE_LENGTH_M,
    MAX_CORRELATION_S,
    UNKNOWN_GRADE_SIGMA_RAD,
    unknown_grade_density,
)
from railnav.filters.ins_clock_model import initial_variances
from railnav.jobs.network import run_files_network
from railnav.jobs.run import read_sensor_files
from railnav.filters.constrained_model import build_constrained_model
from trackmodel.earth import WGS84
from trackmodel.network_routes import load_network

LAT0_DEG, LON0_DEG, LENGTH_M = 50.88, 4.46, 8000.0
#: WGS-84: semi-major axis, m, and flattening.
_A_M, _F = 6378137.0, 1.0 / 298.257223563
WAVE_M, AMPLITUDE_M = 8000.0, 15.0          # grade up to 15·2π/8000 = 1.18 %


def _geojson(path, heights: bool):
    phi = math.radians(LAT0_DEG)
    radius = _A_M / math.sqrt(1.0 - _F * (2.0 - _F) * math.sin(phi) ** 2) * math.cos(phi)
    x = np.arange(0.0, LENGTH_M + 5.0, 10.0)
    columns = [LON0_DEG + np.degrees(x / radius), np.full(x.size, LAT0_DEG)]
    if heights:
        columns.append(100.0 + AMPLITUDE_M * np.sin(2.0 * math.pi * x / WAVE_M))
    feature = {"type": "Feature", "properties": {"id": "E"},
               "geometry": {"type": "LineString",
                            "coordinates": np.column_stack(columns).tolist()}}
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [feature]}))
    return path


@pytest.fixture(scope="module")
def trip(tmp_path_factory):
    """300 s of the curvy profile (a stop, accelerations, 20 m/s) with a tactical IMU and
    single-point fixes, simulated on the graded netelement."""
    tmp = tmp_path_factory.mktemp("grade")
    graded = _geojson(tmp / "graded.geojson", heights=True)
    assert main(["-q", "simulate", "--network", str(graded), "--route", "E", "--imu-grade",
                 "tactical", "--no-gnss", "--fixes-format", "csv", "--fixes-quality",
                 "single=1", "--speed-mps", "20", "--duration-s", "300", "--seed", "1",
                 "--out", str(tmp / "sim")]) == 0
    level = load_network(_geojson(tmp / "level.geojson", heights=False))
    assert not level.heights
    return tmp / "sim", level


def _z(run, sim, level):
    """Normalized along-track and pitch errors of the run's estimates against the truth."""
    est = run.network_result.estimates
    truth = pd.read_csv(sim / "truth.csv")
    t = est["time_s"].to_numpy()
    lat = np.radians(np.interp(t, truth["time_s"], truth["lat_deg"]))
    lon = np.radians(np.interp(t, truth["time_s"], truth["lon_deg"]))
    near = level.project(lat, lon, radius_m=10.0).groupby("point").first()
    assert len(near) == t.size
    offset = near["s_m"].to_numpy()
    z_s = (est["netelement_offset_m"].to_numpy() - offset) / est["sigma_s_m"].to_numpy()
    pitch = np.interp(t, truth["time_s"], truth["pitch_deg"])
    z_pitch = (est["pitch_deg"].to_numpy() - pitch) / est["sigma_pitch_deg"].to_numpy()
    return z_s, z_pitch


def test_the_run_knows_the_grade_is_unknown(trip):
    """On a network without heights an IMU run takes σ_γ = 20 ‰ by itself: its along-track
    and pitch errors are then within their σ (≤ 1 % of the epochs beyond 3σ, the
    project's consistency goal; mean z² below 2: not overconfident; measured 0.33 % and
    1.10 along the track, 0 % and 0.33 in pitch, which the 20-‰ prior leaves wide)."""
    sim, level = trip
    run = run_files_network(level, imu_path=sim / "imu.csv", fixes_path=sim / "fixes.csv")
    assert run.network_result.config.track_grade_sigma_rad == UNKNOWN_GRADE_SIGMA_RAD
    for z in _z(run, sim, level):
        assert np.mean(np.abs(z) > 3.0) <= 0.01 and float(np.mean(z ** 2)) < 2.0


def test_a_level_track_taken_as_known_is_confidently_wrong(trip):
    """The same files with the grade declared known (σ_γ = 0, the behaviour before): the
    pitch follows the level track and the errors are far outside their σ (measured: pitch
    beyond 3σ on every epoch, mean z² 73; along the track 14 % beyond 3σ)."""
    sim, level = trip
    _, config = read_sensor_files(imu_path=sim / "imu.csv", fixes_path=sim / "fixes.csv")
    run = run_files_network(level, imu_path=sim / "imu.csv", fixes_path=sim / "fixes.csv",
                            config=replace(config, track_grade_sigma_rad=0.0))
    z_s, z_pitch = _z(run, sim, level)
    assert np.mean(np.abs(z_pitch) > 3.0) > 0.5 and np.mean(np.abs(z_s) > 3.0) > 0.05


def test_start_pitch_and_density():
    """The start's pitch variance is the attitude's plus σ_γ²; the density is
    ``(a σ_γ)²`` times the time to run `GRADE_LENGTH_M` (capped)."""
    config = replace(NavigatorConfig(imu_errors="tactical"), track_grade_sigma_rad=0.015)
    model = build_constrained_model(WGS84, estimate_biases=True)
    var = initial_variances(config, model.layout)
    assert var["pitch"] == pytest.approx(config.initial_attitude_sigma_rad ** 2 + 0.015 ** 2)
    assert var["yaw"] == pytest.approx(config.initial_attitude_sigma_rad ** 2)
    assert initial_variances(NavigatorConfig(imu_errors="tactical"), model.layout)["pitch"] \
        == pytest.approx(NavigatorConfig().initial_attitude_sigma_rad ** 2)
    a = np.array([0.0, 0.5, -1.0])
    np.testing.assert_allclose(unknown_grade_density(a, 20.0, 0.02),
                               (a * 0.02) ** 2 * GRADE_LENGTH_M / 20.0)
    np.testing.assert_allclose(unknown_grade_density(a, 0.0, 0.02),
                               (a * 0.02) ** 2 * MAX_CORRELATION_S)
