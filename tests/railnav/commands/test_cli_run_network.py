"""``railnav run --network NETWORK --fixes LOG`` (issue 13 §5): the files written, the
route printed, and one-line errors with nothing written. Reference: issue 13's
netelement truth of the log's own carrier-fixed rows (`railnav.evaluation.netelement_truth`)."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from railnav.cli import main

REPO = Path(__file__).resolve().parents[3]
BRUSSELS = str(REPO / "data" / "networks" / "brussels_airport")
EXCERPT = REPO / "data" / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"


def test_fix_log_through_the_network_writes_route_and_hypotheses(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT),
                 "--truth", str(EXCERPT), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "88_L_3842 > 88_L_5900" in text and "netelement right on" in text
    est = pd.read_csv(out / "estimates.csv")
    for col in ("netelement", "netelement_offset_m", "direction", "netelement_probability",
                "mixture_offset_m", "mixture_sigma_m"):
        assert col in est
    assert set(est["direction"]) <= {-1, 1}
    route = pd.read_csv(out / "route.csv")
    assert list(route["netelement"]) == ["88_L_3842", "88_L_5900"]
    assert (route["exit_time_s"] >= route["entry_time_s"]).all()
    hyps = pd.read_csv(out / "hypotheses.csv")
    assert hyps.groupby("time_s")["probability"].sum().sub(1.0).abs().max() < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["route"]["truth"]["share_right"] == 1.0
    assert (out / "network.png").is_file() and (out / "estimates.png").is_file()


def _far_fixes(tmp_path) -> Path:
    raw = pd.read_csv(EXCERPT)
    raw["latitude"] += 0.05                    # 5.5 km north: no track near
    path = tmp_path / "far.csv"
    raw.to_csv(path, index=False)
    return path


@pytest.mark.parametrize("extra, message", [
    (["--start", "88_L_nope"], "--start '88_L_nope': no such netelement"),
    (["--start", "88_L_3842:x"], "NETELEMENT[:OFFSET_M"),
    (["--start", "88_L_3842:99999"], "is not on netelement 88_L_3842"),
    ("far", "within 30 m of a netelement"),
    (["data/tracks/curvy.csv"], "--network replaces TRACK"),
    (["--baro", "b.csv"], "--baro"),
    (["--balises", "b.csv"], "--balises: not with --network"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, extra, message):
    out = tmp_path / "run"
    fixes = str(_far_fixes(tmp_path)) if extra == "far" else str(EXCERPT)
    argv = ["-q", "run", "--network", BRUSSELS, "--fixes", fixes, "--out", str(out),
            "--no-plots"] + ([] if extra == "far" else extra)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err, err
    assert not out.exists()


def test_fix_error_model_flags_are_the_api_config(tmp_path, capsys):
    """``--fix-correlation-s 60 --fix-bias-sigma-m 2`` on the excerpt degraded to
    single-point quality (`railnav.simulation.fix_degrade`, seed 1) writes the estimates of
    `run_files_network` with ``NetworkNavConfig(evidence_correlation_s=60,
    fix_bias_sigma_m=2)``, column for column, and not those of the default (independent
    fixes, no bias): the flags reach the navigator and change its weights."""
    from railnav.jobs.network import load_network, run_files_network, write_network_run
    from railnav.navigation.network_config import NetworkNavConfig
    from railnav.simulation.fix_degrade import degrade_log
    fixes = tmp_path / "spp.csv"
    degrade_log(EXCERPT, fixes, seed=1)
    out = {}
    for name, flags in (("model", ["--fix-correlation-s", "60", "--fix-bias-sigma-m", "2"]),
                        ("default", [])):
        assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(fixes), *flags,
                     "--no-plots", "--out", str(tmp_path / name)]) == 0
        out[name] = pd.read_csv(tmp_path / name / "estimates.csv")
    api = run_files_network(load_network(BRUSSELS), fixes_path=fixes,
                            nav=NetworkNavConfig(evidence_correlation_s=60.0,
                                                 fix_bias_sigma_m=2.0))
    write_network_run(api, tmp_path / "api", plots=False)
    expected = pd.read_csv(tmp_path / "api" / "estimates.csv")
    pd.testing.assert_frame_equal(out["model"], expected)
    assert not out["model"]["netelement_probability"].equals(
        out["default"]["netelement_probability"])


def test_start_abreast_probability_flag_is_the_api_config(tmp_path, capsys):
    """``--start 88_L_2016 --no-spawn --start-abreast-probability 0`` (the train is on
    88_L_3842, 5.6 m abreast) writes the estimates of `run_files_network` with
    ``NetworkNavConfig(spawn=False, start_abreast_probability=0)``, column for column: the
    told netelement alone, which stays wrong on some of the epochs the log's carrier-fixed
    rows put on 3842 (issue 13's netelement truth); by default (P = 0.01) the track abreast
    starts too and every such epoch is right."""
    from railnav.jobs.network import load_network, run_files_network, write_network_run
    from railnav.navigation.network_config import NetworkNavConfig
    from railnav.navigation.network_start import NetworkStart
    share = {}
    for name, flags in (("zero", ["--start-abreast-probability", "0"]), ("default", [])):
        assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT), "--truth",
                     str(EXCERPT), "--start", "88_L_2016", "--no-spawn", *flags,
                     "--no-plots", "--out", str(tmp_path / name)]) == 0
        route = json.loads((tmp_path / name / "summary.json").read_text())["route"]
        share[name] = route["truth"]["share_right"]
    api = run_files_network(load_network(BRUSSELS), fixes_path=EXCERPT,
                            start=NetworkStart("88_L_2016"),
                            nav=NetworkNavConfig(spawn=False, start_abreast_probability=0.0))
    write_network_run(api, tmp_path / "api", plots=False)
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "zero" / "estimates.csv"),
                                  pd.read_csv(tmp_path / "api" / "estimates.csv"))
    assert share["zero"] < 1.0 and share["default"] == 1.0


@pytest.mark.parametrize("argv, message", [
    (["--network", BRUSSELS, "--fixes", str(EXCERPT), "--start", "88_L_2016",
      "--start-abreast-probability", "1"], "--start-abreast-probability 1: must be in [0, 1)"),
    (["--network", BRUSSELS, "--fixes", str(EXCERPT), "--start-abreast-probability", "0.1"],
     "--start-abreast-probability: the prior of the tracks abreast of --start (give it)"),
    (["data/tracks/curvy.csv", "--start-abreast-probability", "0.1"],
     "--start-abreast-probability: only with --network"),
])
def test_start_abreast_probability_bad_input(tmp_path, capsys, argv, message):
    out = tmp_path / "run"
    assert main(["-q", "run", *argv, "--no-plots", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err, err
    assert not out.exists()


def test_fix_error_model_flags_need_fixes(capsys):
    assert main(["-q", "run", "--network", BRUSSELS, "--imu", "x.csv",
                 "--fix-correlation-s", "60", "--out", "never"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "error: --fix-correlation-s: the error model of --fixes (give them)"
    assert main(["-q", "run", "data/tracks/curvy.csv", "--fix-bias-sigma-m", "2"]) == 2
    assert "--fix-bias-sigma-m: only with --network" in capsys.readouterr().err


def test_network_flags_need_a_network(capsys):
    assert main(["-q", "run", "data/tracks/curvy.csv", "--start", "x"]) == 2
    assert "--start: only with --network" in capsys.readouterr().err
    assert main(["-q", "run"]) == 2
    assert "give a TRACK" in capsys.readouterr().err
    assert main(["-q", "run", "--network", BRUSSELS]) == 2
    assert "needs sensor files" in capsys.readouterr().err


def _bad_network(tmp_path, kind: str) -> Path:
    """Issue 13's bad network inputs, each a file small enough to write here."""
    path = tmp_path / {"empty": "empty.geojson", "relation": "rel.geojson",
                       "road": "road.osm"}[kind]
    if kind == "empty":
        path.write_text('{"type": "FeatureCollection", "features": []}')
    elif kind == "relation":
        path.write_text(json.dumps({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {"id": "A"}, "geometry": {
                "type": "LineString", "coordinates": [[4.0, 50.0], [4.0, 50.01]]}},
            {"type": "Feature", "properties": {"netelementA": "A", "netelementB": "Z",
                                               "positionOnA": 1, "positionOnB": 0},
             "geometry": {"type": "Point", "coordinates": [4.0, 50.01]}}]}))
    else:
        path.write_text('<osm version="0.6"><node id="1" lat="50" lon="4"/>'
                        '<node id="2" lat="50.01" lon="4"/><way id="3"><nd ref="1"/>'
                        '<nd ref="2"/><tag k="highway" v="road"/></way></osm>')
    return path


@pytest.mark.parametrize("command", ["run", "network run"])
@pytest.mark.parametrize("kind, message", [
    ("empty", "no LineString netelement"),
    ("relation", "names netelement 'Z', which the file does not have"),
    ("road", "no way tagged railway="),
])
def test_bad_network_files_are_one_line_exit_2_and_nothing_written(tmp_path, capsys,
                                                                   command, kind, message):
    """Issue 13's bad input through both commands that navigate on a network: a GeoJSON
    without netelements, a netrelation naming an unknown netelement, an OSM file without
    a railway; the file named, one line, nothing written."""
    bad, out = _bad_network(tmp_path, kind), tmp_path / "run"
    argv = (["run", "--network", str(bad), "--fixes", str(EXCERPT)] if command == "run"
            else ["network", "run", str(bad), "--start", "A:10", "--duration-s", "5"])
    assert main(["-q", *argv, "--no-plots", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {bad}") and message in err and "\n" not in err, err
    assert not out.exists()


def test_network_run_start_not_in_the_network(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "network", "run", BRUSSELS, "--start", "nope:10", "--duration-s", "5",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"error: {BRUSSELS}: --start 'nope': no such netelement among the "
                   "network's 74") and not out.exists()


def test_spawn_recovers_a_start_on_the_wrong_parallel_track(tmp_path, capsys):
    """Spawning is the default (`NetworkNavConfig.spawn`), ``--no-spawn`` turns it off:
    told to start at 120 m on 88_L_2016, 5.6 m abreast of the train's 88_L_3842 and 111 m
    behind it (where the first fix projects on 2016: 231 m; so far along that the fix
    rejects the abreast tracks there too, `railnav.navigation.network_start.with_abreast`),
    the run without it is wrong on the epochs the log's own carrier-fixed rows put on 3842
    (issue 13's netelement truth); by default, one spawn and the share right rises above
    the run without; ``--spawn`` (accepted, the default) gives the default's numbers.
    ``--spawn`` needs fixes or GNSS observations, and with ``--no-spawn`` is an error.
    Told 88_L_2016 alone (the start fix projected on it, abreast of the train), the track
    abreast starts too and the run is right at every epoch with a truth, without a spawn."""
    share, spawns = {}, {}
    for flag in (["--no-spawn"], [], ["--spawn"]):
        out = tmp_path / ("_".join(flag) or "default")
        assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT), "--truth",
                     str(EXCERPT), "--start", "88_L_2016:120", *flag, "--no-plots",
                     "--out", str(out)]) == 0
        route = json.loads((out / "summary.json").read_text())["route"]
        share[tuple(flag)] = route["truth"]["share_right"]
        spawns[tuple(flag)] = len(route["spawns"])
    out = tmp_path / "abreast"
    assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT), "--truth",
                 str(EXCERPT), "--start", "88_L_2016", "--no-spawn", "--no-plots",
                 "--out", str(out)]) == 0
    route = json.loads((out / "summary.json").read_text())["route"]
    assert route["truth"]["share_right"] == 1.0 and route["spawns"] == []
    assert spawns[("--no-spawn",)] == 0 and spawns[()] >= 1
    assert share[()] > share[("--no-spawn",)]
    assert share[("--spawn",)] == share[()] and spawns[("--spawn",)] == spawns[()]
    assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT), "--spawn",
                 "--no-spawn", "--out", str(tmp_path / "both")]) == 2
    assert "--spawn, --no-spawn: give one" in capsys.readouterr().err
    assert not (tmp_path / "both").exists()
    assert main(["-q", "run", "--network", BRUSSELS, "--imu", "x.csv",
                 "--spawn", "--out", str(tmp_path / "o")]) == 2
    assert "--spawn: needs --fixes or --obs/--nav" in capsys.readouterr().err


def test_gnss_run_spawns_from_single_point_fixes(tmp_path, capsys):
    """A GNSS network run (``--imu --obs --nav``, no fixes) told to start 400 m along
    88_L_111 from where the train is (a trip simulated on the route, the truth's
    ``s_m``: the offset on 88_L_111, travelled towards its first coordinate, is its
    length minus ``s_m``): with ``--no-spawn`` the estimate stays > 100 m off to the end
    and the run ends ``lost`` (the status column and the monitor's counts from the
    epochs' single-point fixes, no spawn); by default it spawns and ends within 10 m of
    the truth, ``ok``.

    The simulated world is the network at h = 0 (a network without heights), so the run
    reads a copy of it whose ``elements.csv`` claims those heights: a file run refuses
    pseudoranges on a network without heights."""
    import shutil

    import numpy as np
    from trackmodel.network_io import read_network
    network = tmp_path / "brussels_h0"
    shutil.copytree(BRUSSELS, network)
    elements = pd.read_csv(network / "elements.csv")
    elements.drop(columns="heights").to_csv(network / "elements.csv", index=False)
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", "--network", BRUSSELS, "--route",
                 "88_L_111,88_L_154,88_L_7815", "--scenario", "curvy", "--duration-s", "40",
                 "--out", str(sim)]) == 0
    length = read_network(BRUSSELS).length_m("88_L_111")
    truth = pd.read_csv(sim / "truth.csv")
    files = ["--imu", str(sim / "imu.csv"), "--obs", str(sim / "gnss_obs.rnx"),
             "--nav", str(sim / "gnss_nav.rnx"), "--no-plots"]
    start = f"88_L_111:{length - 400.0:.1f}:-"
    error, summary, status = {}, {}, {}
    for name, flag in (("off", ["--no-spawn"]), ("default", [])):
        out = tmp_path / name
        assert main(["-q", "run", "--network", str(network), *files, "--start", start, *flag,
                     "--out", str(out)]) == 0
        est = pd.read_csv(out / "estimates.csv")
        truth_offset = length - np.interp(est["time_s"], truth["time_s"], truth["s_m"])
        assert est["netelement"].iloc[-1] == "88_L_111"
        error[name] = float(est["netelement_offset_m"].iloc[-1] - truth_offset[-1])
        summary[name] = json.loads((out / "summary.json").read_text())
        status[name] = set(est["status"])
    assert summary["off"]["route"]["spawns"] == [] and abs(error["off"]) > 100.0
    assert "lost" in status["off"]
    assert summary["off"]["statistics"]["monitor"]["final_status"] == "lost"
    assert len(summary["default"]["route"]["spawns"]) >= 1 and abs(error["default"]) < 10.0
    assert summary["default"]["statistics"]["monitor"]["final_status"] == "ok"
    assert status["default"] <= {"ok", "degraded", "lost"}


def test_simulated_files_are_scored_against_their_truth(tmp_path, capsys):
    """``railnav simulate --network`` then ``railnav run --network`` on its fixes: the
    run finds the ``truth.csv`` beside ``scenario.json`` (as a single-track run does) and
    scores the netelements against it; ``--truth truth.csv`` gives the same scores, a
    reference class with it is a one-line error. Reference: the simulated route itself
    (the truth's unambiguous netelements, in order, are its elements)."""
    from trackmodel.network_io import read_network
    route = ["88_L_111", "88_L_154", "88_L_7815"]
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", "--network", BRUSSELS, "--route", ",".join(route),
                 "--scenario", "curvy", "--duration-s", "90", "--no-gnss", "--fixes-format",
                 "csv", "--fixes-quality", "rtk_fixed=1", "--out", str(sim)]) == 0
    scores = {}
    for name, extra in (("default", []), ("given", ["--truth", str(sim / "truth.csv")])):
        out = tmp_path / name
        assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(sim / "fixes.csv"),
                     "--no-plots", *extra, "--out", str(out)]) == 0
        summary = json.loads((out / "summary.json").read_text())["route"]
        assert summary["netelements"][-1] == route[0]      # 90 s: still on the first
        # it stood 10 s at the first's joint: each element once (its fix-only mean
        # crossed the joint back and forth), no element but the first and the one joined
        # to it there (the network's connections)
        joined = {e for e, _ in read_network(BRUSSELS).successors(route[0], 1)}
        assert len(set(summary["netelements"])) == len(summary["netelements"])
        assert set(summary["netelements"]) <= {route[0]} | joined
        scores[name] = summary["truth"]
    truth = scores["default"]
    assert scores["given"] == truth
    assert truth["epochs"] > 50 and truth["share_right"] == 1.0
    assert truth["navigable"] and truth["passes_truth"]
    capsys.readouterr()
    out = tmp_path / "quality"
    assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(sim / "fixes.csv"),
                 "--truth", str(sim / "truth.csv"), "--truth-quality", "single",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "applies to a fix file only" in err and "\n" not in err
    assert not out.exists()
