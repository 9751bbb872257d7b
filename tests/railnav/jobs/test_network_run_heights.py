"""Runs of recorded fixes on a network without heights write no height; on one with heights
they write the track's. References: the closed-form heights of the test netelement and of
its fixes (`tests.support.height_networks`), the export formats read back by independent
readers (json, xml.dom.minidom, gpxpy, pynmea2) and by our own fix reader."""
from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from xml.dom import minidom

import gpxpy
import numpy as np
import pandas as pd
import pynmea2
import pytest

from gnss_obs.fixes.read import read_fixes
from railnav.errors import ConfigError
from railnav.jobs.export import write_exports
from railnav.jobs.network import run_files_network, write_network_run
from railnav.navigation.result import HEIGHT_COLUMNS
from tests.support.height_networks import height_m, write_fixes, write_geojson
from trackmodel.fit_defaults import DEFAULT_VTOL_M
from trackmodel.network import Network
from trackmodel.network_routes import load_network

#: Column names that may stand in the documentation's paragraph on runs without heights.
ESTIMATE_NAMES = {"h_m", "v_up_mps", "sigma_up_m", "pitch_deg", "sigma_pitch_deg", "lat_deg",
                  "lon_deg", "v_east_mps", "v_north_mps", "sigma_east_m", "sigma_north_m",
                  "yaw_deg", "roll_deg", "speed_mps", "s_m"}
#: The estimate's height against the netelement's closed-form height at its offset: the
#: vertical profile's fit aim (0.14 m measured) plus the along-track error (cm, rtk fixes)
#: times the grade (<= 2 %).
ATOL_H_M = DEFAULT_VTOL_M


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("network_heights")
    fixes = write_fixes(tmp / "fixes.csv")
    out = {}
    for heights in (True, False):
        net = load_network(write_geojson(tmp / f"net_{heights}.geojson", heights=heights))
        run = run_files_network(net, fixes_path=fixes)
        write_network_run(run, tmp / f"run_{heights}", plots=False)
        out[heights] = (run, tmp / f"run_{heights}")
    return out, fixes


def _csv_cells(path, column) -> list[str]:
    with open(path, newline="") as f:
        return [row[column] for row in csv.DictReader(f)]


def test_without_heights_the_height_columns_are_empty(runs):
    _, out = runs[0][False]
    for column in ("h_m", "v_up_mps", "sigma_up_m"):
        assert set(_csv_cells(out / "estimates.csv", column)) == {""}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["heights"] is False
    kinds = set(pd.read_csv(out / "innovations.csv")["kind"])
    assert kinds == {"fix_along", "fix_cross"}          # the fixes' heights not used
    est = pd.read_csv(out / "estimates.csv")
    assert est["lat_deg"].notna().all() and est["speed_mps"].notna().all()


def test_with_heights_the_estimates_follow_the_track(runs):
    run, out = runs[0][True]
    est = pd.read_csv(out / "estimates.csv")
    assert est[["h_m", "v_up_mps", "sigma_up_m"]].notna().all().all()
    np.testing.assert_allclose(est["h_m"], height_m(est["netelement_offset_m"]),
                               atol=ATOL_H_M)
    assert json.loads((out / "summary.json").read_text())["heights"] is True
    assert "fix_up" in set(pd.read_csv(out / "innovations.csv")["kind"])


def test_the_same_tracks_taken_as_heights_lose_every_fix(runs):
    """What the flag prevents: the 2-D network's tracks (h = 0) with heights claimed (as
    before the flag), the fixes' heights ~100 m above them fail the gate and every fix
    epoch is rejected whole; read as without heights, the fixes' horizontal rows are
    used."""
    (run, out), fixes = runs[0][False], runs[1]
    claimed = run_files_network(Network(run.network.elements, [], heights=True),
                                fixes_path=fixes).outcome.result.innovations
    up = claimed[claimed["kind"] == "fix_up"]
    assert (up["innovation"] > 90.0).all()                 # the fixes' h - 0
    assert set(claimed["status"]) == {"rejected"}
    rows = pd.read_csv(out / "innovations.csv")
    assert (rows["status"] == "used").mean() > 0.9


def test_pseudoranges_on_a_network_without_heights_are_refused(runs):
    (run, _), fixes = runs[0][False], runs[1]
    with pytest.raises(ConfigError, match="this network has no heights: pseudorange runs "
                                          "need a track with heights"):
        run_files_network(run.network, fixes_path=fixes, obs_path="obs.rnx",
                          nav_path="nav.rnx")


def test_height_columns_are_the_documented_ones():
    """docs/file-formats.md names the columns a run without heights leaves empty."""
    text = (Path(__file__).resolve().parents[3] / "docs" / "file-formats.md").read_text()
    paragraph = text[text.index("On a network **without heights**"):]
    paragraph = paragraph[:paragraph.index("\n\n")]
    named = {c for c in re.findall(r"`([a-z_]+)`", paragraph) if c in ESTIMATE_NAMES}
    assert set(HEIGHT_COLUMNS) == named


def test_exports_without_heights_have_none(runs, tmp_path):
    run, _ = runs[0][False]
    est = run.outcome.result.estimates
    write_exports(est, tmp_path)
    doc = json.loads((tmp_path / "trajectory.geojson").read_text())
    assert {len(f["geometry"]["coordinates"]) for f in doc["features"][1:]} == {2}
    assert {len(p) for p in doc["features"][0]["geometry"]["coordinates"]} == {2}
    assert all(f["properties"]["h_m"] is None for f in doc["features"][1:])
    kml = minidom.parse(str(tmp_path / "trajectory.kml"))
    modes = {m.firstChild.data for m in kml.getElementsByTagName("altitudeMode")}
    assert modes == {"clampToGround"}
    point = kml.getElementsByTagName("Point")[0]
    assert len(point.getElementsByTagName("coordinates")[0].firstChild.data.split(",")) == 2
    gpx = gpxpy.parse((tmp_path / "trajectory.gpx").read_text())
    points = gpx.tracks[0].segments[0].points
    assert len(points) == len(est)
    assert all(p.elevation is None and p.geoid_height is None for p in points)
    lines = (tmp_path / "trajectory.nmea").read_text().splitlines()
    gga = [pynmea2.parse(s) for s in lines if s.startswith("$GPGGA")]
    gst = [pynmea2.parse(s) for s in lines if s.startswith("$GPGST")]
    assert len(gga) == len(gst) == len(est)
    assert all(m.altitude is None and m.geo_sep == "" for m in gga)
    assert all(m.std_dev_altitude is None and m.std_dev_latitude is not None for m in gst)
    back = read_fixes(tmp_path / "trajectory.nmea").table
    assert back["h_m"].isna().all()
    np.testing.assert_allclose(back["sigma_north_m"], est["sigma_north_m"], atol=1e-4)


def test_exports_with_heights_carry_them(runs, tmp_path):
    run, _ = runs[0][True]
    est = run.outcome.result.estimates
    write_exports(est, tmp_path, ("gpx", "nmea"))
    points = gpxpy.parse((tmp_path / "trajectory.gpx").read_text()).tracks[0].segments[0].points
    np.testing.assert_allclose([p.elevation for p in points], est["h_m"], atol=1e-9)
    back = read_fixes(tmp_path / "trajectory.nmea").table
    np.testing.assert_allclose(back["h_m"], est["h_m"], atol=1e-4)   # GGA: 4 decimals
