"""Issue 18: ``railnav run --export geojson,kml,gpx,nmea``, each export read back by an
independent reader (json, xml.dom.minidom, gpxpy.parse, pynmea2.parse) and compared with
the estimates.csv it came from; optional columns (the protection interval ``s_min_m`` /
``s_max_m`` a later branch adds) pass through."""
from __future__ import annotations

import json
import math
from xml.dom import minidom

import gpxpy
import numpy as np
import pandas as pd
import pynmea2
import pytest

from gnss_obs.gpstime import from_gps_time_s, gps_time_s_to_calendar
from railnav.cli import main
from railnav.jobs.export import GPX_NAMESPACE, write_exports
from railnav.simulation.scenarios import TRACKS_DIR

PAPER = str(TRACKS_DIR / "paper2017.csv")
#: Degrees of NMEA latitude/longitude: 1e-7 minute.
NMEA_DEG = 1e-7 / 60
#: The exports carry the estimates at full precision, estimates.csv to 12 significant
#: digits (`railnav.navigation.result.CSV_FLOAT_FORMAT`).
CSV_RTOL = 1e-11


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("exports") / "run"
    assert main(["-q", "run", PAPER, "--duration-s", "8", "--no-plots", "--export",
                 "geojson,kml,gpx,nmea", "--out", str(out)]) == 0
    return out, pd.read_csv(out / "estimates.csv")


def test_issue18_geojson_read_back(exported):
    out, est = exported
    doc = json.loads((out / "trajectory.geojson").read_text())
    assert doc["type"] == "FeatureCollection"
    line, *points = doc["features"]
    coords = np.array(line["geometry"]["coordinates"])
    np.testing.assert_allclose(coords, est[["lon_deg", "lat_deg", "h_m"]].to_numpy(),
                               rtol=CSV_RTOL)
    assert len(points) == len(est)
    props = pd.DataFrame([p["properties"] for p in points])
    pd.testing.assert_frame_equal(props[est.columns], est, check_dtype=False, rtol=CSV_RTOL)


def _utc_calendar(gps_time_s: float):
    return tuple(np.asarray(v).item() for v in gps_time_s_to_calendar(
        float(from_gps_time_s(gps_time_s, "UTC"))))


def test_issue18_kml_read_back(exported):
    out, est = exported
    doc = minidom.parse(str(out / "trajectory.kml"))
    line = doc.getElementsByTagName("LineString")[0]
    coords = [[float(v) for v in p.split(",")] for p in
              line.getElementsByTagName("coordinates")[0].firstChild.data.split()]
    np.testing.assert_allclose(coords, est[["lon_deg", "lat_deg", "h_m"]].to_numpy(),
                               rtol=CSV_RTOL)
    marks = [m for m in doc.getElementsByTagName("Placemark")
             if m.getElementsByTagName("TimeStamp")]
    assert len(marks) == len(est)
    k = len(est) // 2
    data = {d.getAttribute("name"): d.getElementsByTagName("value")[0].firstChild.data
            for d in marks[k].getElementsByTagName("Data")}
    assert float(data["sigma_east_m"]) == pytest.approx(est["sigma_east_m"].iloc[k],
                                                        rel=CSV_RTOL)
    when = marks[k].getElementsByTagName("when")[0].firstChild.data
    y, mo, d, h, mi, s = _utc_calendar(est["gps_time_s"].iloc[k])
    assert when.startswith(f"{y:04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}:{int(s):02d}")


def test_issue18_gpx_read_back(exported):
    out, est = exported
    gpx = gpxpy.parse((out / "trajectory.gpx").read_text())
    points = gpx.tracks[0].segments[0].points
    assert len(points) == len(est)
    np.testing.assert_allclose([p.latitude for p in points], est["lat_deg"], rtol=CSV_RTOL)
    np.testing.assert_allclose([p.longitude for p in points], est["lon_deg"], rtol=CSV_RTOL)
    # GPX ele is above mean sea level, geoidheight the geoid above the ellipsoid
    np.testing.assert_allclose([p.elevation + p.geoid_height for p in points], est["h_m"],
                               rtol=CSV_RTOL)
    k = len(est) // 3
    values = {e.tag.split("}")[1]: e.text for e in points[k].extensions[0]}
    assert points[k].extensions[0].tag == f"{{{GPX_NAMESPACE}}}estimate"
    assert float(values["sigma_north_m"]) == pytest.approx(est["sigma_north_m"].iloc[k],
                                                           rel=CSV_RTOL)
    course = math.degrees(math.atan2(est["v_east_mps"].iloc[k], est["v_north_mps"].iloc[k]))
    assert float(values["course_deg"]) == pytest.approx(course % 360.0, abs=1e-8)
    y, mo, d, h, mi, s = _utc_calendar(est["gps_time_s"].iloc[k])
    t = points[k].time
    assert (t.year, t.month, t.day, t.hour, t.minute, t.second) == (y, mo, d, h, mi, int(s))


def test_issue18_nmea_read_back(exported):
    out, est = exported
    sentences = [pynmea2.parse(line) for line in
                 (out / "trajectory.nmea").read_text().splitlines()]
    gga = [s for s in sentences if s.sentence_type == "GGA"]
    gst = [s for s in sentences if s.sentence_type == "GST"]
    rmc = [s for s in sentences if s.sentence_type == "RMC"]
    assert len(gga) == len(gst) == len(rmc) == len(est)
    np.testing.assert_allclose([g.latitude for g in gga], est["lat_deg"], rtol=0,
                               atol=NMEA_DEG)
    np.testing.assert_allclose([g.longitude for g in gga], est["lon_deg"], rtol=0,
                               atol=NMEA_DEG)
    assert {g.gps_qual for g in gga} == {6}             # estimated (dead reckoning)
    np.testing.assert_allclose([float(g.std_dev_latitude) for g in gst],
                               est["sigma_north_m"], rtol=0, atol=5e-5)
    np.testing.assert_allclose([float(g.std_dev_altitude) for g in gst],
                               est["sigma_up_m"], rtol=0, atol=5e-5)
    knots = 1852.0 / 3600.0
    np.testing.assert_allclose([r.spd_over_grnd * knots for r in rmc], est["speed_mps"],
                               rtol=0, atol=1e-4 * knots)


def test_issue18_optional_columns_pass_through(tmp_path, exported):
    _, est = exported
    est = est.assign(s_min_m=est["s_m"] - 2.5, s_max_m=est["s_m"] + 3.5)
    paths = write_exports(est, tmp_path, ("geojson", "kml", "gpx"))
    props = [f["properties"] for f in json.loads(paths[0].read_text())["features"][1:]]
    assert [p["s_max_m"] for p in props] == est["s_max_m"].tolist()
    names = {d.getAttribute("name") for d in minidom.parse(str(paths[1]))
             .getElementsByTagName("Data")}
    assert {"s_min_m", "s_max_m"} <= names
    point = gpxpy.parse(paths[2].read_text()).tracks[0].segments[0].points[0]
    values = {e.tag.split("}")[1]: e.text for e in point.extensions[0]}
    assert float(values["s_min_m"]) == est["s_min_m"].iloc[0]


def test_issue18_unknown_export_format_is_refused_before_work(tmp_path, capsys):
    assert main(["-q", "run", PAPER, "--export", "geojson,shp", "--out",
                 str(tmp_path / "o")]) == 2
    assert "--export 'geojson,shp': formats are geojson, kml, gpx, nmea" in \
        capsys.readouterr().err
    assert not (tmp_path / "o").exists()
