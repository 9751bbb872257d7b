"""``railnav simulate``: files and columns as documented, and the `perfect` imu.csv checked
against an independent derivation from truth.csv alone (ECEF finite differences, Earth
rotation, normal gravity) — the acceptance check of the issue."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from railnav.cli import main
from railnav.simulation.truth import TRUTH_COLUMNS
from strapdown.euler import C_b_n
from strapdown.gravity import g_n
from strapdown.imu import IMU_COLUMNS
from trackmodel.earth import WGS84, C_n_e, geodetic_to_ecef, sphere
from trackmodel.io import write_track
from trackmodel.sections import Section
from trackmodel.track import Track

# Acceptance thresholds of the issue (95th percentile of |difference|): well under the
# Coriolis acceleration 2Ωv ≈ 3e-3 m/s² at 20 m/s.
P95_FORCE_MPS2 = 5e-4
P95_RATE_RADPS = 1e-6


@pytest.fixture
def curvy_file(tmp_path):
    """A WGS-84 track with a clothoid-arc-clothoid curve and a vertical curve."""
    sections = [Section(1500.0, 75.0, 0.2), Section(150.0, None, None, 0.0, 1 / 800),
                Section(500.0, None, None, 1 / 800), Section(150.0, None, None, 1 / 800, 0.0),
                Section(400.0, None, None, elevation_end_deg=0.6), Section(20000.0, None, None)]
    path = tmp_path / "curvy_test.csv"
    write_track(Track.from_sections(sections, lat=np.radians(48.0), lon=np.radians(11.0),
                                    h=500.0, earth=WGS84), path)
    return path


@pytest.fixture
def paper_file(tmp_path):
    path = tmp_path / "paper_test.csv"
    write_track(Track.from_sections([Section(25000.0, 30.0, 3.0)], lat=np.radians(50.45),
                                    lon=np.radians(30.52), h=100.0, earth=sphere()), path)
    return path


def derive_imu_from_truth(truth: pd.DataFrame, earth) -> tuple[np.ndarray, np.ndarray]:
    """Specific force and inertial rate (body axes) from truth.csv columns only.

    4th-order central differences of the ECEF position; f = r̈ + 2Ω×ṙ − g (normal gravity
    rotated to ECEF); ω_ib_b = C_e_b Ω + vee(C_b_eᵀ dC_b_e/dt). Rows 2..N-3.
    """
    t = truth["time_s"].to_numpy()
    dt = t[1] - t[0]
    lat, lon = np.radians(truth["lat_deg"].to_numpy()), np.radians(truth["lon_deg"].to_numpy())
    h = truth["h_m"].to_numpy()
    r = geodetic_to_ecef(lat, lon, h, earth=earth)
    k = slice(2, -2)
    rv = (-r[4:] + 8 * r[3:-1] - 8 * r[1:-3] + r[:-4]) / (12 * dt)
    ra = (-r[4:] + 16 * r[3:-1] - 30 * r[2:-2] + 16 * r[1:-3] - r[:-4]) / (12 * dt * dt)
    omega = np.array([0.0, 0.0, earth.omega_radps])
    C_ne = C_n_e(lat, lon)
    g_e = np.einsum("nij,nj->ni", C_ne[k], g_n(lat[k], h[k], earth=earth))
    f_e = ra + 2 * np.cross(omega, rv) - g_e
    ang = [np.radians(truth[c].to_numpy()) for c in ("yaw_deg", "pitch_deg", "roll_deg")]
    C_be = C_ne @ C_b_n(*ang)
    C_eb = np.swapaxes(C_be, 1, 2)
    dC = (-C_be[4:] + 8 * C_be[3:-1] - 8 * C_be[1:-3] + C_be[:-4]) / (12 * dt)
    W = C_eb[k] @ dC
    w_eb = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                           W[:, 1, 0] - W[:, 0, 1]], axis=-1)
    return (np.einsum("nij,nj->ni", C_eb[k], f_e),
            np.einsum("nij,j->ni", C_eb[k], omega) + w_eb)


@pytest.mark.parametrize("which, scenario, earth", [("curvy_file", "curvy", WGS84),
                                                    ("paper_file", "paper2017", sphere())])
def test_perfect_imu_matches_truth_csv_derivation(request, tmp_path, capsys, which, scenario,
                                                  earth):
    track = request.getfixturevalue(which)
    out = tmp_path / "out"
    code = main(["-q", "simulate", str(track), "--scenario", scenario, "--imu-grade", "perfect",
                 "--duration-s", "600", "--seed", "3", "--out", str(out), "--no-gnss"])
    assert code == 0
    truth = pd.read_csv(out / "truth.csv")
    imu = pd.read_csv(out / "imu.csv")
    assert tuple(truth.columns) == TRUTH_COLUMNS and tuple(imu.columns) == IMU_COLUMNS
    f_ref, w_ref = derive_imu_from_truth(truth, earth)
    f = imu[list(IMU_COLUMNS[1:4])].to_numpy()[2:-2]
    w = imu[list(IMU_COLUMNS[4:7])].to_numpy()[2:-2]
    assert np.percentile(np.abs(f - f_ref), 95) < P95_FORCE_MPS2
    assert np.percentile(np.abs(w - w_ref), 95) < P95_RATE_RADPS
    meta = json.loads((out / "scenario.json").read_text())
    assert meta["scenario"]["name"] == scenario and meta["seed"] == 3
    assert meta["scenario"]["imu_errors"]["name"] == "perfect"


def test_overrides_outages_and_measured_imu(tmp_path, paper_file):
    out = tmp_path / "o"
    code = main(["-q", "simulate", str(paper_file), "--scenario", "paper2017", "--speed-mps",
                 "10", "--duration-s", "20", "--outage", "5:2", "--outage", "10:1.5",
                 "--imu-grade", "mems", "--seed", "1", "--out", str(out)])
    assert code == 0
    truth = pd.read_csv(out / "truth.csv")
    imu = pd.read_csv(out / "imu.csv")
    assert len(truth) == 2001 and truth["time_s"].iloc[-1] == pytest.approx(20.0)
    np.testing.assert_allclose(truth["speed_mps"], 10.0)
    assert truth["s_m"].iloc[-1] == pytest.approx(200.0, abs=1e-9)
    meta = json.loads((out / "scenario.json").read_text())
    assert meta["scenario"]["outages"] == [[5.0, 2.0], [10.0, 1.5]]
    assert meta["gnss_written"] is True and meta["gnss_systems"] == "G"
    # GNSS at 1 Hz from the scenario's start time, none inside the outage windows
    obs = read_rinex_obs(out / "gnss_obs.rnx")
    epochs = np.unique(obs.table["gps_time_s"]) - meta["scenario"]["start_gps_time_s"]
    expected = [t for t in range(21) if not (5 <= t < 7 or 10 <= t < 11.5)]
    np.testing.assert_allclose(epochs, expected, atol=1e-6)
    assert read_rinex_nav(out / "gnss_nav.rnx").records["G"].shape[0] > 0
    # mems noise: per-sample σ of the accelerometers is 150 µg·sqrt(100 Hz) ≈ 0.015 m/s².
    assert np.std(np.diff(imu["ax_mps2"])) > 0.01


def test_trip_ends_at_track_end(tmp_path, paper_file):
    out = tmp_path / "end"
    # --scenario paper2017 (constant speed: 25 km at 50 m/s = 500 s): simulate's default
    # was paper2017, it now follows run's rule (the track's name, else curvy; issue 18)
    assert main(["-q", "simulate", str(paper_file), "--scenario", "paper2017",
                 "--speed-mps", "50", "--duration-s", "1000",
                 "--imu-grade", "perfect", "--out", str(out), "--no-gnss"]) == 0
    truth = pd.read_csv(out / "truth.csv")
    assert truth["s_m"].iloc[-1] <= 25000.0 and truth["time_s"].iloc[-1] == pytest.approx(500.0)


def test_bad_track_file_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg\n1,2,3,abc,30,3\n")
    out = tmp_path / "never"
    code = main(["simulate", str(bad), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error:") and "bad.csv" in err and "\n" not in err
    assert not (out / "truth.csv").exists()


def test_issue18_simulate_says_what_it_wrote(tmp_path, capsys, paper_file):
    out = tmp_path / "said"
    assert main(["-q", "simulate", str(paper_file), "--duration-s", "2", "--imu-grade",
                 "perfect", "--out", str(out), "--no-gnss"]) == 0
    printed = capsys.readouterr().out.strip()
    names = printed.split(": ", 1)[1].split(" (")[0].split(", ")
    assert sorted(names) == sorted(p.name for p in out.iterdir())
    samples = len(pd.read_csv(out / "truth.csv"))
    assert f"({samples} IMU samples" in printed
