"""OpenStreetMap railway ways as netelements and connections (`read_osm`, via `osmium`).

**What is read.** Ways tagged ``railway=`` one of `RAILWAY_KINDS`, from an ``.osm`` (XML),
``.osm.pbf`` or compressed extract that `osmium` (pyosmium) reads, with the locations of
their nodes. Nodes without a location (a way cut at the extract's border) are dropped
with one warning.

**Netelements.** Each way is split at its *split nodes*: ``railway=switch`` and
``railway=railway_crossing`` nodes, and nodes that several ways share (or that one way
passes twice: a loop). A way not split is netelement ``w<way id>``; a split one gives
``w<way id>_1``, ``_2``, ... in the way's order. Each netelement keeps its way's ``railway``,
``gauge``, ``service`` and ``usage`` tags and ``osm_way`` as attributes.

**Connections and navigability.** Where netelement ends meet at a node, every pair of ends
is a connection:

* at a *plain* node (two ends, no switch or crossing tag) a train passes both ways,
  unless the two legs form a V (deflection above `MAX_PLAIN_DEFLECTION_DEG`: seen where two
  tram tracks cut at an extract's border end on one node);
* anywhere else (a switch, tagged or not, and crossings) the geometry decides. Each end's
  *leg* is its direction away from the node, measured to the point `LEG_M` along it (or
  its far end). A train passes between two legs when they are nearly opposite: the
  *deflection* ``π − angle(leg a, leg b)`` is at most `MAX_DEFLECTION_DEG`. At a switch
  the trunk passes to both branches (deflections of a few degrees: 1:9 is 6.3°, a tram's
  ~10-20°) and the two branches, ~170° apart in deflection, do not pass. At a
  ``railway=railway_crossing`` node (a diamond) a leg passes only to the leg most
  opposite it, so a shallow crossing is not taken for a switch.

A way tagged ``oneway=yes`` (``true``, ``1``) is travelled in its own direction only (the
order of its nodes: each of its netelements from its first coordinate to its last),
``oneway=-1`` (``reverse``) against it (`ONEWAY`; ``no`` or any other value: both ways).
A connection then passes only the ways that leave one netelement and enter the other in
a direction each allows: ``AB``, ``BA`` or ``none`` instead of ``both``. The tag is kept
as the netelements' ``oneway`` attribute.

A piece of way whose points all lie within `MIN_ELEMENT_M` of its first cannot be fitted:
it is dropped and its two end nodes are made one (with a warning naming it).

Netelements then are fitted like any others (`trackmodel.network_io.build_network`); OSM
has no heights, so the tracks have ``h = 0``, a placeholder, and the network says so
(`trackmodel.network.Network` ``heights`` False).
"""
from __future__ import annotations

import logging
import math
import os
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from trackmodel.errors import TrackFileError
from trackmodel.network import END, START, Connection
from trackmodel.network_io import NetworkSource
from trackmodel.network_project import MEAN_RADIUS_M
from trackmodel.polyline import MIN_SPACING_M

__all__ = ["read_osm", "RAILWAY_KINDS", "MAX_DEFLECTION_DEG", "LEG_M", "OSM_SUFFIXES",
           "ONEWAY"]

Array = npt.NDArray[np.float64]

log = logging.getLogger(__name__)

#: ``railway=`` values read as track.
RAILWAY_KINDS = ("rail", "light_rail", "tram", "subway", "narrow_gauge")
#: Way tags kept as netelement attributes.
KEPT_TAGS = ("railway", "gauge", "service", "usage", "oneway")
#: ``oneway=`` values and the one direction they allow along the way's nodes (+1 their
#: order, -1 against it); others allow both.
ONEWAY = {"yes": 1, "true": 1, "1": 1, "-1": -1, "reverse": -1}
#: Node tags that split a way.
SWITCH, CROSSING = "switch", "railway_crossing"
#: Largest deflection between two legs a train passes at a switch, deg (module docstring).
MAX_DEFLECTION_DEG = 45.0
#: At a plain node two ends whose legs deflect more than this (a V: the ways meet head on,
#: e.g. two tracks cut at the extract's border on one node) do not pass, deg.
MAX_PLAIN_DEFLECTION_DEG = 90.0
#: A leg's direction is measured to the point this far along it, m.
LEG_M = 10.0
#: A piece of way whose points all lie within this of its first is contracted to a node,
#: m: the fitter's smallest point spacing (`trackmodel.polyline.MIN_SPACING_M`).
MIN_ELEMENT_M = MIN_SPACING_M
#: File names osmium reads (by their ending).
OSM_SUFFIXES = (".osm", ".osm.pbf", ".pbf", ".osm.bz2", ".osm.gz", ".o5m", ".opl")


@dataclass
class _Way:
    id: int
    nodes: list[int]
    lat: Array
    lon: Array
    tags: dict[str, str]


def read_osm(path: str | os.PathLike) -> NetworkSource:
    """Netelements, connections and attributes of the railway ways in an OSM file
    (module docstring).

    Raises
    ------
    TrackFileError
        A file osmium cannot read, or one without any railway way of `RAILWAY_KINDS`.
    """
    ways, node_tags = _read(Path(path))
    if not ways:
        raise TrackFileError(f"no way tagged railway={'|'.join(RAILWAY_KINDS)} with two "
                             "located nodes", path=path)
    uses: dict[int, int] = defaultdict(int)
    for way in ways:
        for node in way.nodes:
            uses[node] += 1
    splits = {n for n, count in uses.items() if count > 1} | set(node_tags)
    pieces = [(name, way, i, j) for way in ways for name, (i, j) in _pieces(way, splits)]
    merged = _contract(pieces, path)
    polylines, attributes, ends, oneway = {}, {}, defaultdict(list), {}
    for name, way, i, j in pieces:
        lat, lon = way.lat[i:j + 1], way.lon[i:j + 1]
        if _extent_m(lat, lon) < MIN_ELEMENT_M:
            continue
        polylines[name] = (lat, lon)
        attributes[name] = {"osm_way": str(way.id),
                            **{k: way.tags[k] for k in KEPT_TAGS if k in way.tags}}
        oneway[name] = ONEWAY.get(way.tags.get("oneway", "").strip().lower(), 0)
        ends[merged(way.nodes[i])].append((name, START, _leg(lat, lon)))
        ends[merged(way.nodes[j])].append((name, END, _leg(lat[::-1], lon[::-1])))
    tags = {merged(n): kind for n, kind in sorted(node_tags.items(), key=lambda x: x[1])}
    connections = []
    for node, here in ends.items():
        connections.extend(_connections(here, tags.get(node), oneway))
    return NetworkSource(polylines, tuple(connections), attributes)


def _contract(pieces, path):
    """Pieces whose points all lie within `MIN_ELEMENT_M` of their first (no track can be
    fitted to them) are dropped and their two end nodes made one, so the ends that met at
    either meet there (OSRD's issue 8903: a 9-cm way left an isolated section). Returns
    the map from a node to its representative."""
    parent: dict[int, int] = {}

    def find(node: int) -> int:
        while parent.get(node, node) != node:
            node = parent[node]
        return node

    for name, way, i, j in pieces:
        if _extent_m(way.lat[i:j + 1], way.lon[i:j + 1]) < MIN_ELEMENT_M:
            log.warning("%s: way %d (%s) between nodes %d and %d is shorter than %g m: "
                        "dropped, its two ends joined", path, way.id, name, way.nodes[i],
                        way.nodes[j], MIN_ELEMENT_M)
            a, b = find(way.nodes[i]), find(way.nodes[j])
            if a != b:
                parent[max(a, b)] = min(a, b)
    return find


def _plane(lat: Array, lon: Array) -> tuple[Array, Array]:
    """East and north of the points from the first, m (local equirectangular plane)."""
    north = MEAN_RADIUS_M * (lat - lat[0])
    east = MEAN_RADIUS_M * math.cos(lat[0]) * ((lon - lon[0] + math.pi) % (2 * math.pi)
                                                - math.pi)
    return east, north


def _extent_m(lat: Array, lon: Array) -> float:
    """Largest distance of a point from the first, m."""
    return float(np.max(np.hypot(*_plane(lat, lon))))


def _read(path: Path) -> tuple[list[_Way], dict[int, str]]:
    """The railway ways (with located nodes) and the switch/crossing nodes' tags."""
    import osmium  # heavy: only when an OSM file is read
    if not path.is_file():
        raise TrackFileError("no such file", path=path)
    ways, node_tags, dropped = [], {}, 0
    try:
        processor = osmium.FileProcessor(str(path), osmium.osm.NODE | osmium.osm.WAY)
        for obj in processor.with_locations():
            if obj.is_node():
                kind = obj.tags.get("railway")
                if kind in (SWITCH, CROSSING):
                    node_tags[obj.id] = kind
            elif obj.is_way() and obj.tags.get("railway") in RAILWAY_KINDS:
                way, lost = _way(obj)
                dropped += lost
                if way is not None:
                    ways.append(way)
    except TrackFileError:
        raise
    except Exception as exc:                     # osmium's C++ errors arrive as several types
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise TrackFileError(f"not a readable OSM file ({text})", path=path) from None
    if dropped:
        log.warning("%s: %d node(s) of railway ways have no location (cut at the extract's "
                    "border?): dropped", path, dropped)
    return ways, node_tags


def _way(obj) -> tuple[_Way | None, int]:
    """A railway way with its located nodes, and the number of nodes without location."""
    nodes, lat, lon = [], [], []
    for n in obj.nodes:
        if n.location.valid():
            nodes.append(int(n.ref))
            lat.append(math.radians(n.location.lat))
            lon.append(math.radians(n.location.lon))
    lost = len(obj.nodes) - len(nodes)
    if len(nodes) < 2:
        return None, lost
    tags = {t.k: t.v for t in obj.tags}
    return _Way(int(obj.id), nodes, np.array(lat), np.array(lon), tags), lost


def _pieces(way: _Way, splits: set[int]) -> list[tuple[str, tuple[int, int]]]:
    """``(netelement id, (first, last) node index)`` of the way cut at its split nodes."""
    cuts = [0] + [i for i in range(1, len(way.nodes) - 1) if way.nodes[i] in splits] + [
        len(way.nodes) - 1]
    spans = list(zip(cuts[:-1], cuts[1:]))
    if len(spans) == 1:
        return [(f"w{way.id}", spans[0])]
    return [(f"w{way.id}_{k}", span) for k, span in enumerate(spans, start=1)]


def _leg(lat: Array, lon: Array) -> float:
    """Azimuth of the polyline leaving its first point, to the point `LEG_M` along it (or
    its last), rad (local equirectangular plane)."""
    east, north = _plane(lat, lon)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(east), np.diff(north)))])
    reach = min(LEG_M, float(along[-1]))
    x, y = np.interp(reach, along, east), np.interp(reach, along, north)
    return math.atan2(x, y)


def _deflection(a: float, b: float) -> float:
    """π minus the angle between two legs, rad (0: a straight passage)."""
    return math.pi - abs((a - b + math.pi) % (2 * math.pi) - math.pi)


def _travel(oneway: dict[str, int], a: str, a_end: int, b: str, b_end: int) -> bool:
    """Whether a train may leave netelement `a` through its end `a_end` and go on along `b`
    from its end `b_end`, as their ``oneway`` directions allow (+1 along the element, -1
    against it, 0 either)."""
    leaving = 1 if a_end == END else -1
    entering = 1 if b_end == START else -1
    return oneway.get(a, 0) in (0, leaving) and oneway.get(b, 0) in (0, entering)


def _navigability(passes: bool, oneway: dict[str, int], a, a_end, b, b_end) -> str:
    """``both``, ``AB``, ``BA`` or ``none``: the geometry's verdict, then the one-way
    tags."""
    ab = passes and _travel(oneway, a, a_end, b, b_end)
    ba = passes and _travel(oneway, b, b_end, a, a_end)
    return "both" if ab and ba else "AB" if ab else "BA" if ba else "none"


def _connections(here: list[tuple[str, int, float]], tag: str | None,
                 oneway: dict[str, int] | None = None) -> list[Connection]:
    """Every pair of the ends meeting at one node, with its navigability (module
    docstring; `oneway`: each netelement's direction from its way's ``oneway`` tag)."""
    oneway = oneway or {}
    out = []
    plain = tag is None and len(here) == 2 and _deflection(here[0][2], here[1][2]) <= (
        math.radians(MAX_PLAIN_DEFLECTION_DEG))
    limit = math.radians(MAX_DEFLECTION_DEG)
    best = {i: min((j for j in range(len(here)) if j != i),
                   key=lambda j: _deflection(here[i][2], here[j][2]), default=None)
            for i in range(len(here))}
    for i in range(len(here)):
        for j in range(i + 1, len(here)):
            (a, a_end, leg_a), (b, b_end, leg_b) = here[i], here[j]
            passes = _deflection(leg_a, leg_b) <= limit
            if tag == CROSSING:
                passes = passes and best[i] == j and best[j] == i
            out.append(Connection(a, a_end, b, b_end,
                                  _navigability(plain or passes, oneway, a, a_end, b, b_end)))
    return out
