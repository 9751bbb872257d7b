"""``railnav simulate --fixes-format`` and ``railnav run --fixes/--truth`` in-process: the
files written, scoring against truth.csv / a trajectory / a fix file, scenario.json's
outages honoured, real Belgian excerpts (a fix far off the track rejected), one-line
errors."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from pyubx2 import GET, UBXMessage

from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR
from tests.conftest import REPO

PAPER = str(TRACKS_DIR / "paper2017.csv")
BRUSSELS = REPO / "data" / "tracks" / "brussels"
EXCERPTS = REPO / "data" / "fixes" / "brussels"
#: A fix this far from the track is not used (the screen's gate is ~3.7σ of
#: √(σ_fix² + 1.5²) m across, ≤ 10 m even for a single-point fix).
FAR_M = 50.0
#: Within this a single-point fix (σ 2.5 m, + 1.5 m for the track) is ~2σ across: used.
NEAR_M = 5.0


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """paper2017 for 40 s with a GNSS outage 10-15 s, NMEA fixes at 1 Hz."""
    sim = tmp_path_factory.mktemp("sim")
    assert main(["-q", "simulate", PAPER, "--duration-s", "40", "--outage", "10:5",
                 "--fixes-format", "nmea", "--fixes-quality", "dgps=1", "--no-gnss",
                 "--seed", "3", "--out", str(sim)]) == 0
    return sim


def test_simulate_writes_nmea_fixes_and_records_them(simulated):
    meta = json.loads((simulated / "scenario.json").read_text())
    assert meta["fixes"]["file"] == "fixes.nmea" and meta["fixes"]["format"] == "nmea"
    lines = (simulated / "fixes.nmea").read_text().splitlines()
    gga = [line for line in lines if line.startswith("$GPGGA")]
    # 1 Hz over 0..40 s without the 5 s of the outage: 41 - 5 fixes
    assert len(gga) == meta["fixes"]["count"] == 36
    assert all(line.split(",")[6] == "2" for line in gga)      # GGA quality 2: DGPS


def test_fix_only_run_finds_truth_and_outages(simulated, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--fixes", str(simulated / "fixes.nmea"),
                 "--out", str(out)]) == 0
    for name in ("estimates.csv", "innovations.csv", "summary.json", "errors.csv",
                 "errors.png", "track.png"):
        assert (out / name).is_file(), name
    est = pd.read_csv(out / "estimates.csv")
    assert list(est.columns[:4]) == ["time_s", "gps_time_s", "timestamp", "s_m"]
    assert est["timestamp"].iloc[0].endswith("Z") and est["time_s"].iloc[0] == 0.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == "gnss-only" and summary["outages"] == [[10.0, 5.0]]
    assert summary["reference"]["source"] == "truth"
    assert summary["errors"]["outages"][0]["start_s"] == 10.0
    inn = pd.read_csv(out / "innovations.csv")
    assert not ((inn["time_s"] >= 10) & (inn["time_s"] < 15)).any()
    assert set(inn["kind"]) == {"fix_along", "fix_cross", "fix_up", "fix_speed"}
    assert "GNSS fixes" in capsys.readouterr().out


def test_truth_as_a_reference_trajectory(simulated, tmp_path):
    """The truth rewritten as gps_time_s, lat, lon, h: the along-track errors equal those
    against truth.csv where both are given (same positions, same track)."""
    meta = json.loads((simulated / "scenario.json").read_text())
    truth = pd.read_csv(simulated / "truth.csv")
    ref = pd.DataFrame({"gps_time_s": truth["time_s"] + meta["scenario"]["start_gps_time_s"],
                        "lat_deg": truth["lat_deg"], "lon_deg": truth["lon_deg"],
                        "h_m": truth["h_m"]})
    ref.to_csv(tmp_path / "ref.csv", index=False, float_format="%.12f")
    runs = {}
    for name, extra in (("truth", []), ("trajectory", ["--truth", str(tmp_path / "ref.csv")])):
        assert main(["-q", "run", PAPER, "--fixes", str(simulated / "fixes.nmea"),
                     "--no-plots", *extra, "--out", str(tmp_path / name)]) == 0
        runs[name] = pd.read_csv(tmp_path / name / "errors.csv")
    assert json.loads((tmp_path / "trajectory" / "summary.json").read_text())[
        "reference"]["source"] == "trajectory"
    ok = runs["trajectory"]["along_track_m"].notna()
    assert ok.mean() > 0.9
    np.testing.assert_allclose(runs["trajectory"]["along_track_m"][ok],
                               runs["truth"]["along_track_m"][ok], atol=1e-4)   # 0.1 mm


def test_imu_and_csv_fixes_run_the_constrained_filter(tmp_path):
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "20", "--fixes-format", "csv",
                 "--no-gnss", "--out", str(sim)]) == 0
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--imu", str(sim / "imu.csv"), "--fixes",
                 str(sim / "fixes.csv"), "--no-plots", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == "constrained" and summary["statistics"]["fix_epochs"] == 21
    assert "timestamp" in pd.read_csv(out / "estimates.csv", nrows=1).columns


def test_belgian_excerpt_scored_against_its_fixed_rows(tmp_path):
    log = EXCERPTS / "log_28876_L36-B_excerpt.csv"
    out = tmp_path / "b"
    assert main(["-q", "run", str(BRUSSELS / "log_28876_L36-B.csv"), "--fixes", str(log),
                 "--truth", str(log), "--no-plots", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    raw = pd.read_csv(log)
    assert summary["reference"]["candidates"] == (raw["position_type"] == "NARROW_INT3").sum()
    assert summary["errors"]["all"]["along_track_m"]["rms"] is not None
    est = pd.read_csv(out / "estimates.csv")
    assert est["timestamp"].iloc[0] == raw["timestamp"].iloc[0] + ".000"[
        len(raw["timestamp"].iloc[0]) - 19:]      # ISO to the ms, no zone, as the file


def test_belgian_fixes_far_off_the_track_are_rejected(tmp_path):
    """log_29083: the rows far from the track (projection, a second method) are all
    rejected by the fault screen; the single-point rows within `NEAR_M` mostly used."""
    from gnss_obs.fixes.read import read_fixes
    from trackmodel.io import read_track
    log, track = EXCERPTS / "log_29083_L36-A_excerpt.csv", BRUSSELS / "log_29083_L36-A.csv"
    out = tmp_path / "d"
    assert main(["-q", "run", str(track), "--fixes", str(log), "--no-plots",
                 "--out", str(out)]) == 0
    fixes = read_fixes(log).table
    proj = read_track(track).project(np.radians(fixes["lat_deg"]), np.radians(fixes["lon_deg"]))
    offset = pd.Series(np.hypot(proj.cross_track_m, proj.along_m),
                       index=fixes["gps_time_s"].round(3))
    inn = pd.read_csv(out / "innovations.csv")
    along = inn[inn["kind"] == "fix_along"].set_index(inn["gps_time_s"].round(3)
                                                      [inn["kind"] == "fix_along"])
    far = offset[offset > FAR_M].index.intersection(along.index)
    near = offset[offset < NEAR_M].index.intersection(along.index)
    assert len(far) > 20 and (along.loc[far, "status"] == "rejected").all()
    assert len(near) > 20 and (along.loc[near, "status"] == "used").mean() > 0.9


def _ubx_without_pvt(path):
    path.write_bytes(UBXMessage("NAV", "NAV-STATUS", GET, iTOW=1000).serialize())
    return path


@pytest.mark.parametrize("make, extra, message", [
    (lambda p: (p.write_text("$GPGGA,1*00\n"), p)[1], [], "bad checksum"),
    (_ubx_without_pvt, [], "no NAV-PVT"),
    (None, ["--fix-sigma", "single=4"], "--fix-sigma: only with --fixes"),
    (lambda p: (p.write_text("gps_time_s,lat_deg,lon_deg\n1,50,4\n2,50,4\n"), p)[1],
     ["--filter", "unconstrained"], "needs --imu"),
    (lambda p: (p.write_text("gps_time_s,lat_deg,lon_deg\n1,50,4\n2,50,4\n"), p)[1],
     ["--fix-sigma", "nope=1"], "--fix-sigma"),
    (None, ["--truth", "x.csv"], "--truth: a simulated run"),
    (None, ["--correlated-fix-errors"], "--correlated-fix-errors: only with --fixes"),
])
def test_bad_fix_input_is_one_line_exit_2(tmp_path, capsys, make, extra, message):
    fixes = [] if make is None else ["--fixes", str(make(tmp_path / "fixes.dat"))]
    code = main(["-q", "run", PAPER, *fixes, *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert err.startswith("error: ") and message in err and "\n" not in err
    if make is not None and not extra:
        assert str(tmp_path / "fixes.dat") in err


def test_fixes_on_two_tracks_identify_the_track(tmp_path):
    """Issue 13: a run over candidate tracks is a network run, so it takes position fixes
    (the gnss-only filter on them). Fixes simulated on track B (RTK float, decimetres,
    against 4.5 m between the tracks: tens of nats per fix): B, and the track columns."""
    double = [str(TRACKS_DIR / "double_a.csv"), str(TRACKS_DIR / "double_b.csv")]
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", double[1], "--scenario", "curvy", "--duration-s", "30",
                 "--no-gnss", "--fixes-format", "csv", "--fixes-quality", "rtk_float=1",
                 "--out", str(sim)]) == 0
    out = tmp_path / "o"
    assert main(["-q", "run", *double, "--fixes", str(sim / "fixes.csv"), "--no-plots",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == "gnss-only"
    assert summary["track_probabilities"]["double_b"] > 0.99
    est = pd.read_csv(out / "estimates.csv")
    assert (est["track"].iloc[len(est) // 2:] == "double_b").all()
    assert list(pd.read_csv(out / "track_probabilities.csv").columns) == [
        "time_s", "gps_time_s", "double_a", "double_b", "common_rows"]


@pytest.mark.parametrize("extra, message", [
    (["--fixes-quality", "single=1"], "only with --fixes-format"),
    (["--fixes-format", "nmea", "--fixes-quality", "best=1"], "is not CLASS=WEIGHT"),
    (["--fixes-format", "csv", "--fixes-rate-hz", "3"], "must divide"),
])
def test_bad_simulate_fix_flags_are_one_line_exit_2(tmp_path, capsys, extra, message):
    code = main(["-q", "simulate", PAPER, "--duration-s", "5", "--no-gnss", *extra,
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o").exists()          # nothing half written


@pytest.mark.parametrize("imu", [True, False])
def test_fixes_together_with_pseudoranges(tmp_path, imu):
    """GNSS observations and fixes of the same epochs: one epoch with both kinds of rows
    (the pseudorange rows of each epoch and its fix rows share its time), the fixes
    screened, scored against truth.csv."""
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "20", "--fixes-format", "csv",
                 "--fixes-quality", "rtk_float=1", "--out", str(sim)]) == 0
    out = tmp_path / "run"
    files = ["--obs", str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"),
             "--fixes", str(sim / "fixes.csv")] + (["--imu", str(sim / "imu.csv")] if imu
                                                    else [])
    assert main(["-q", "run", PAPER, *files, "--no-plots", "--out", str(out)]) == 0
    inn = pd.read_csv(out / "innovations.csv")
    kinds = inn.groupby("epoch")["kind"].agg(set)
    assert all({"pseudorange", "fix_along"} <= k for k in kinds)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == ("constrained" if imu else "gnss-only")
    assert summary["statistics"]["fix_epochs"] == len(kinds)
    # rtk_float fixes (σ 0.5 m) dominate the along-track position: errors of that order
    assert summary["errors"]["all"]["along_track_m"]["rms"] < 3 * 0.5


def test_file_run_starts_with_its_first_fixs_sigma(tmp_path):
    """Regression (issue 17): a run on railnav simulate's files took the scenario's initial
    σ (0.1 m/s: the spread of run_simulated's draw about the truth) for a start from a
    single-point fix whose speed error is ~1 m/s (paper2017's σ_rr 0.71 m/s), rejected the
    Doppler and fixes that disagreed, and ended with NEES ~130. Reference: the σ of the
    single-point solution at the start (gnss_obs.solve_spp through first_fix), projected
    on the track's tangent."""
    from railnav.filters.protocol import make_filter
    from railnav.jobs.run import read_sensor_files
    from railnav.navigation.initialization import first_fix, initial_from_gnss
    from railnav.navigation.navigator import trip_samples
    from trackmodel.io import read_track
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "10", "--out", str(sim)]) == 0
    paths = dict(imu_path=sim / "imu.csv", obs_path=sim / "gnss_obs.rnx",
                 nav_path=sim / "gnss_nav.rnx")
    data, config = read_sensor_files(**paths)
    track = read_track(PAPER)
    filt = make_filter(track, config, trip_samples(data, config).gnss)
    start = initial_from_gnss(filt, data, config, filt.rows.gnss)
    fix = first_fix(data, config)
    u_n = track.at(0.0).u_n
    i_v = filt.layout.index("v")
    assert np.sqrt(start.P0[i_v, i_v]) == pytest.approx(
        np.sqrt(u_n @ fix.cov_v_enu_m2ps2 @ u_n), rel=1e-9)
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, *[f"--{k[:3]}={v}" for k, v in paths.items()],
                 "--no-plots", "--out", str(out)]) == 0
    est, errors = pd.read_csv(out / "estimates.csv"), pd.read_csv(out / "errors.csv")
    assert (np.abs(errors["along_track_m"]) <= 3 * est["sigma_s_m"]).all()


def test_ubx_fixes_run_end_to_end_without_a_utc_timestamp(tmp_path):
    """The Belgian excerpt's fixed rows as NAV-PVT messages built by pyubx2 (iTOW from the
    timestamps + 18 leap seconds, hAcc 2 cm, carrier fixed, the velocity from the
    positions' differences, sAcc 0.3 m/s): the run uses every one and writes no
    `timestamp` column (UBX time is GPS time of week)."""
    import datetime as dt
    raw = pd.read_csv(EXCERPTS / "log_28876_L36-B_excerpt.csv")
    raw = raw[raw["position_type"] == "NARROW_INT3"].reset_index(drop=True)
    t = pd.to_datetime(raw["timestamp"], format="ISO8601").to_numpy(
        dtype="datetime64[ns]").astype(np.int64) / 1e9
    north_m = np.radians(raw["latitude"].to_numpy()) * 6_371_000.0     # velocity from the
    east_m = np.radians(raw["longitude"].to_numpy()) * 6_371_000.0 * np.cos(  # positions'
        np.radians(raw["latitude"].to_numpy()))                        # differences
    vel_n, vel_e = np.gradient(north_m, t), np.gradient(east_m, t)
    chunks = []
    for k, row in raw.iterrows():
        utc = dt.datetime.fromisoformat(row["timestamp"])
        gps = (utc - dt.datetime(1980, 1, 6)).total_seconds() + 18
        chunks.append(UBXMessage(
            "NAV", "NAV-PVT", GET, iTOW=int(round((gps % 604_800) * 1000)), year=utc.year,
            month=utc.month, day=utc.day, hour=utc.hour, min=utc.minute, second=utc.second,
            nano=utc.microsecond * 1000, validDate=1, validTime=1, fixType=3, gnssFixOk=1,
            carrSoln=2, numSV=14, lat=row["latitude"], lon=row["longitude"], height=0,
            hAcc=20, vAcc=30, velN=int(vel_n[k] * 1000), velE=int(vel_e[k] * 1000),
            sAcc=300).serialize())
    (tmp_path / "log.ubx").write_bytes(b"".join(chunks))
    out = tmp_path / "u"
    assert main(["-q", "run", str(BRUSSELS / "log_28876_L36-B.csv"), "--fixes",
                 str(tmp_path / "log.ubx"), "--no-fix-heights", "--no-plots",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["fixes"]["format"] == "ubx" and summary["fixes"]["read"] == len(raw)
    assert summary["statistics"]["fixes_rejected"] == 0
    assert "timestamp" not in pd.read_csv(out / "estimates.csv", nrows=1).columns


def test_correlated_fix_errors_on_real_single_point_fixes(tmp_path, capsys):
    """Issue 14 on real data: the urban drive excerpt's own GPS single-point fixes
    (``railnav spp``), run alone on the excerpt's track and scored against the PPK
    reference trajectory (independent of both). Taken as white (the default) their
    correlated errors make σ_s a promise broken on ~16 % of the whole seconds (every
    epoch ``degraded``, and the run prints the hint); with --correlated-fix-errors the
    share beyond 3σ_s is within issue 14's 1 % and the monitor says ``ok``."""
    gnss = REPO / "data" / "gnss"
    assert main(["-q", "spp", "--obs", str(gnss / "rover_obs_1240.rnx"), "--nav",
                 str(gnss / "broadcast_nav.rnx"), "--systems", "G",
                 "--out", str(tmp_path / "spp")]) == 0
    capsys.readouterr()
    shares = {}
    for flag in ([], ["--correlated-fix-errors"]):
        out = tmp_path / ("correlated" if flag else "white")
        assert main(["run", str(REPO / "data" / "tracks" / "barcelona_drive.csv"),
                     "--fixes", str(tmp_path / "spp" / "spp.csv"), "--truth",
                     str(gnss / "reference_trajectory_1240.csv"), "--no-plots",
                     "--out", str(out), *flag]) == 0
        printed = capsys.readouterr().out
        assert ("--correlated-fix-errors" in printed) == (not flag)     # the hint
        est = pd.read_csv(out / "estimates.csv")
        err = pd.read_csv(out / "errors.csv").merge(est, on="time_s")
        err = err[np.isclose(err["time_s"] % 1.0, 0.0)]
        z = err["along_track_m"] / err["sigma_s_m"]
        assert len(z) > 150
        shares[bool(flag)] = (float((z.abs() > 3.0).mean()), float((err["status"] == "ok").mean()))
    assert shares[False][0] > 0.05 and shares[False][1] < 0.5
    assert shares[True][0] <= 0.01 and shares[True][1] > 0.9


@pytest.mark.parametrize("where", [["--network", str(REPO / "data" / "networks"
                                                    / "brussels_switch.geojson")],
                                   [PAPER, PAPER]])
def test_correlated_fix_errors_only_on_one_track(tmp_path, capsys, where):
    """--correlated-fix-errors is the gnss-only filter's on one track: a network run (its
    stacked fix rows do not inflate) or candidate tracks get a one-line error, exit 2."""
    fixes = tmp_path / "fixes.csv"
    fixes.write_text("gps_time_s,lat_deg,lon_deg\n1,50,4\n2,50,4\n")
    code = main(["-q", "run", *where, "--fixes", str(fixes), "--correlated-fix-errors",
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error: ") and "one track only" in err
    assert "\n" not in err and not (tmp_path / "o").exists()


def test_own_fix_file_as_reference_with_smooth_warns_once(tmp_path, capsys):
    """Audit finding: ``--fixes F --truth F --smooth`` read F three times (the run, its
    score, the smoothed twin's score): each warning of the reader printed three times,
    the reference's twice. Now F is read once. The excerpt of log 29083 has a row whose
    solution status is not SOL_COMPUTED (no fix) and its carrier-fixed rows are off the
    track."""
    log_file = EXCERPTS / "log_29083_L36-A_excerpt.csv"
    table = pd.read_csv(log_file)
    no_fix = int((table["solution_status"] != "SOL_COMPUTED").sum())
    assert main(["run", str(BRUSSELS / "log_29083_L36-A.csv"), "--fixes", str(log_file),
                 "--truth", str(log_file), "--smooth", "--no-plots",
                 "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err.splitlines()
    read = [line for line in err if "fixes read; skipped" in line]
    assert len(read) == 1 and read[0].endswith(f"skipped {no_fix} no fix")
    assert sum("agrees with the track: no reference" in line for line in err) == 1


def test_a_reference_without_samples_writes_no_error_files(tmp_path, capsys):
    """Audit finding: a reference none of whose samples is usable (log 29083's carrier-fixed
    rows, all 90-200 m off the track) gave errors.csv and smoothed_errors.csv of empty rows
    and 'RMS n/a m'. Now neither is written and the report says 'no reference'."""
    log_file = EXCERPTS / "log_29083_L36-A_excerpt.csv"
    carrier_fixed = int((pd.read_csv(log_file)["position_type"] == "NARROW_INT3").sum())
    out = tmp_path / "o"
    assert main(["run", str(BRUSSELS / "log_29083_L36-A.csv"), "--fixes", str(log_file),
                 "--truth", str(log_file), "--smooth", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reference"]["candidates"] == summary["reference"]["off_track"] \
        == carrier_fixed
    assert summary["reference"]["estimates_compared"] == 0
    assert "n/a" not in text and "no reference: no estimate has a reference sample" in text
    assert "smoothed (RTS): no reference" in text
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["estimates.csv", "innovations.csv", "smoothed.csv", "summary.json",
         "estimates.png", "track.png"])


@pytest.mark.parametrize("sep, words", [(";", "separated by semicolons (';')"),
                                        ("\t", "separated by tabs")])
def test_a_fix_table_with_another_separator_says_so(tmp_path, capsys, sep, words):
    """Audit finding: the Brussels excerpt re-saved with ';' (a European spreadsheet's
    CSV) was 'not a fix file this reader knows'. Its header splits on the separator into
    the excerpt's own columns; the error now names the separator."""
    from gnss_obs.fixes.read import detect_fix_format
    log_file = EXCERPTS / "log_28876_L36-B_excerpt.csv"
    other = tmp_path / "log.csv"
    other.write_text(log_file.read_text().replace(",", sep))
    columns = list(pd.read_csv(log_file, nrows=0).columns)
    assert other.read_text().splitlines()[0].split(sep) == columns
    assert detect_fix_format(log_file) == "csv"
    code = main(["run", str(BRUSSELS / "log_28876_L36-B.csv"), "--fixes", str(other),
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith(f"error: {other}: a table {words}")
    assert "\n" not in err and not (tmp_path / "o").exists()


def test_fixes_of_another_line_name_the_fix_file_and_the_track(tmp_path, capsys):
    """The Brussels excerpt's fixes (50.9° N, 4.5° E) run on the paper's track (near
    50.45° N, 30.5° E): no fix is near the track, so none can start the filter. One line
    that names both files, exit 2, nothing written; it named neither."""
    fixes = REPO / "data" / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--fixes", str(fixes), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {fixes}: none of the first")
    assert f"(track {PAPER})" in err and not out.exists()
