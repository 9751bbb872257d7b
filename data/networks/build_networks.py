"""Build the shipped networks from the Brussels GeoJSON (tp-lib's test data, Apache-2.0).

    python data/networks/build_networks.py --geojson PATH/network_airport.geojson

writes ``data/networks/brussels_airport/`` (every netelement fitted with
`trackmodel.network_io.build_network`, tolerance 0.5 m, radius >= 15 m; ~30 s) and
``data/networks/brussels_switch.geojson`` (an excerpt for the reader tests: the three
netelements of the switch at the west end of ``88_L_9755`` and the relations among them,
coordinates unchanged).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from trackmodel.network_io import build_network, read_network_geojson, write_network

HERE = Path(__file__).resolve().parent
SWITCH = {"88_L_9755", "88_L_11801", "88_L_2014"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--geojson", required=True, type=Path,
                        help="network_airport.geojson (tp-lib test-data)")
    args = parser.parse_args()
    network = build_network(read_network_geojson(args.geojson))
    write_network(network, HERE / "brussels_airport")
    data = json.loads(args.geojson.read_text())
    keep = [f for f in data["features"]
            if f["properties"].get("id") in SWITCH
            or {f["properties"].get("netelementA"), f["properties"].get("netelementB")} <= SWITCH]
    (HERE / "brussels_switch.geojson").write_text(
        json.dumps({"type": "FeatureCollection", "features": keep}, indent=1) + "\n")


if __name__ == "__main__":
    main()
