"""``railnav run --network`` on the shipped Brussels network, which has no heights (its
source, tp-lib's GeoJSON, is [lon, lat] pairs): the heights of every output are empty, not
0 m. References: the shipped files' own columns and coordinates; the export formats read
back by gpxpy and pynmea2."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import gpxpy
import pandas as pd
import pynmea2

from railnav.cli import main

REPO = Path(__file__).resolve().parents[3]
BRUSSELS = str(REPO / "data" / "networks" / "brussels_airport")
EXCERPT = REPO / "data" / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"


def test_brussels_run_writes_no_height(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "run", "--network", BRUSSELS, "--fixes", str(EXCERPT), "--no-plots",
                 "--export", "gpx,nmea", "--out", str(out)]) == 0
    with open(out / "estimates.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows
    for column in ("h_m", "v_up_mps", "sigma_up_m"):
        assert {r[column] for r in rows} == {""}, column
    assert all(r["lat_deg"] and r["sigma_east_m"] for r in rows)
    assert json.loads((out / "summary.json").read_text())["heights"] is False
    assert "fix_up" not in set(pd.read_csv(out / "innovations.csv")["kind"])
    points = gpxpy.parse((out / "trajectory.gpx").read_text()).tracks[0].segments[0].points
    assert len(points) == len(rows) and all(p.elevation is None for p in points)
    assert "<ele>" not in (out / "trajectory.gpx").read_text()
    gga = [pynmea2.parse(s) for s in (out / "trajectory.nmea").read_text().splitlines()
           if s.startswith("$GPGGA")]
    assert len(gga) == len(rows) and all(m.altitude is None for m in gga)


def test_network_info_says_no_heights(capsys):
    assert main(["network", "info", BRUSSELS]) == 0
    assert "no heights" in capsys.readouterr().out.splitlines()[0]


def test_route_of_a_network_without_heights_is_marked(tmp_path, capsys):
    out = tmp_path / "route.csv"
    assert main(["network", "route", BRUSSELS, "--elements", "88_L_5916,88_L_2026",
                 "--out", str(out)]) == 0
    assert "# the network has no heights: h = 0 is a placeholder" in out.read_text()
    assert "the network has no heights" in capsys.readouterr().err


def test_a_run_whose_fixes_are_all_rejected_says_it_ended_lost(tmp_path, capsys):
    """Fixes 100 m above the network's heights (tests.support.height_networks): every fix
    row is rejected (the vertical row fails the gate and takes the fix with it) while the
    fixes agree horizontally. The run exits 0, prints its status counts and that it ended
    ``lost`` (railnav.navigation.network_status), and the summary says so."""
    from tests.support.height_networks import write_fixes, write_geojson
    network = write_geojson(tmp_path / "net.geojson", heights=True)
    fixes = write_fixes(tmp_path / "fixes.csv")
    table = pd.read_csv(fixes)
    table["h_m"] += 100.0
    table.to_csv(fixes, index=False, float_format="%.12f")
    out = tmp_path / "run"
    assert main(["run", "--network", str(network), "--fixes", str(fixes), "--no-plots",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "LOST at the end of the run" in printed
    rows = pd.read_csv(out / "innovations.csv")
    assert set(rows["status"]) == {"rejected"}
    monitor = json.loads((out / "summary.json").read_text())["statistics"]["monitor"]
    assert monitor["final_status"] == "lost"
    e = monitor["epochs"]
    assert f"monitor: {e['ok']} ok, {e['degraded']} degraded, {e['lost']} lost" in printed
    assert e["lost"] >= rows["epoch"].nunique() - 1
