"""``railnav network import|check|plot|route|info`` (issue 13): files written and read back
by the library's own readers, lines printed, and bad input as one line, exit 2, nothing
written.

References: the shipped files' topology as their readers give it (`trackmodel`), the
route line of `Network.route_track`, and the PNG signature of the written plots.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from railnav.cli import main
from trackmodel.io import read_track
from trackmodel.network_io import read_network
from trackmodel.network_routes import route_legs

DATA = Path(__file__).resolve().parents[3] / "data"
NETWORKS = DATA / "networks"
BRUSSELS = str(NETWORKS / "brussels_airport")
HANDMADE = str(NETWORKS / "osm" / "handmade.osm")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_import_osm_and_info(tmp_path, capsys):
    out = tmp_path / "net"
    assert main(["-q", "network", "import", HANDMADE, "--out", str(out)]) == 0
    assert "8 netelements" in capsys.readouterr().out
    net = read_network(out)
    assert net.attributes["w3"]["service"] == "siding"
    assert ("w3", 1) in net.successors("w1", 1)
    assert main(["network", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "netelements by railway=: rail 6, tram 2" in text and "checks: 0 error(s)" in text


def test_import_to_geojson_reads_back(tmp_path, capsys):
    out = tmp_path / "h.geojson"
    assert main(["-q", "network", "import", HANDMADE, "--out", str(out)]) == 0
    from trackmodel.network_io import read_network_geojson
    from trackmodel.osm import read_osm
    again, first = read_network_geojson(out), read_osm(HANDMADE)
    assert sorted(again.polylines) == sorted(first.polylines)
    assert again.attributes == first.attributes


def test_import_track_csv_is_one_element(tmp_path, capsys):
    out = tmp_path / "net"
    assert main(["-q", "network", "import", str(DATA / "tracks" / "curvy.csv"),
                 "--out", str(out)]) == 0
    assert list(read_network(out).elements) == ["curvy"]


def test_route_by_elements_as_a_track_file(tmp_path, capsys):
    out = tmp_path / "route.csv"
    assert main(["-q", "network", "route", BRUSSELS, "--elements",
                 "88_L_111,88_L_154,88_L_7815", "--out", str(out)]) == 0
    assert "-88_L_111>-88_L_154>-88_L_7815" in capsys.readouterr().out
    net = read_network(BRUSSELS)
    line = net.route_track(route_legs(net, "88_L_111,88_L_154,88_L_7815"))
    written = read_track(out)
    s = np.linspace(0.0, line.length_m, 300)
    assert written.length_m == pytest.approx(line.length_m, abs=1e-6)
    assert np.max(np.linalg.norm(written.at(s).r_e - line.at(s).r_e, axis=1)) < 1e-3


def test_route_between_positions(capsys):
    assert main(["network", "route", BRUSSELS, "--from", "88_L_111:1000:-",
                 "--to", "88_L_7815:100"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    net = read_network(BRUSSELS)
    from trackmodel.network import NetPosition
    best = net.routes(NetPosition("88_L_111", 1000.0, -1), NetPosition("88_L_7815", 100.0))[0]
    assert first.startswith("0:") and f"{best.length_m:.1f} m" in first


def test_check_lists_findings_and_import_refuses_errors(tmp_path, capsys):
    line = {"type": "Feature", "properties": {"id": "A"},
            "geometry": {"type": "LineString", "coordinates": [[4.0, 50.0], [4.0, 50.01]]}}
    twin = {**line, "properties": {"id": "B"}}
    path = tmp_path / "dup.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [line, twin]}))
    assert main(["-q", "network", "check", str(path)]) == 2
    out = capsys.readouterr().out
    assert "error: " in out and "A, B: the two netelements coincide" in out
    target = tmp_path / "net"
    assert main(["-q", "network", "import", str(path), "--out", str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "duplicates" in err and "\n" not in err
    assert not target.exists()


def test_plot_with_route_and_fixes(tmp_path, capsys):
    out = tmp_path / "map.png"
    fixes = DATA / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"
    assert main(["-q", "network", "plot", BRUSSELS, "--route", "88_L_111,88_L_154",
                 "--fixes", str(fixes), "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert main(["-q", "network", "plot", HANDMADE, "--out", str(tmp_path / "h.png")]) == 0


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("make, args, message", [
    (lambda d: _write(d, "empty.geojson", '{"type": "FeatureCollection", "features": []}'),
     ["import"], "no LineString netelement"),
    (lambda d: _write(d, "rel.geojson", json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "A"}, "geometry": {
            "type": "LineString", "coordinates": [[4.0, 50.0], [4.0, 50.01]]}},
        {"type": "Feature", "properties": {"netelementA": "A", "netelementB": "Z",
                                           "positionOnA": 1, "positionOnB": 0},
         "geometry": {"type": "Point", "coordinates": [4.0, 50.01]}}]})),
     ["import"], "netelement 'Z'"),
    (lambda d: _write(d, "road.osm", '<osm version="0.6"><node id="1" lat="50" lon="4"/>'
                      '<node id="2" lat="50.01" lon="4"/><way id="3"><nd ref="1"/>'
                      '<nd ref="2"/><tag k="highway" v="road"/></way></osm>'),
     ["import"], "no way tagged railway="),
    (lambda d: BRUSSELS, ["route", "--elements", "88_L_111,nope"],
     "--elements 'nope': no such netelement"),
    (lambda d: BRUSSELS, ["route", "--elements", "88_L_154,88_L_2014"], "no passage"),
    (lambda d: BRUSSELS, ["route"], "give --elements"),
    (lambda d: _write(d, "x.txt", "x"), ["info"], "not a network"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, make, args, message):
    source = make(tmp_path)
    out = tmp_path / "out"
    argv = ["-q", "network", args[0], source, *args[1:]]
    if args[0] == "import":
        argv += ["--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not out.exists()
