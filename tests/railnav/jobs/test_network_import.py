"""`railnav.import_network` (``railnav network import``'s function): what it writes is the
network `trackmodel.network_routes.load_network` reads from the source (reference: that
reader, called directly, and `read_network` of the folder written), and a network whose
check finds an error is refused with nothing written.
"""
from __future__ import annotations

import json

import pytest

from railnav.errors import ConfigError
from railnav.jobs.network_import import import_network
from tests.conftest import DATA
from trackmodel.network_io import read_network
from trackmodel.network_routes import load_network

SWITCH = DATA / "networks" / "brussels_switch.geojson"


def test_writes_the_network_the_source_holds(tmp_path):
    network, warnings = import_network(SWITCH, tmp_path / "net")
    direct = load_network(SWITCH)
    written = read_network(tmp_path / "net")
    assert sorted(written.elements) == sorted(direct.elements) == sorted(network.elements)
    for name, track in direct.elements.items():
        assert written.elements[name].length_m == pytest.approx(track.length_m, abs=1e-6)
    assert all(f.level == "warning" for f in warnings)


def test_a_check_error_writes_nothing(tmp_path):
    line = {"type": "Feature", "properties": {"id": "A"},
            "geometry": {"type": "LineString", "coordinates": [[4.0, 50.0], [4.0, 50.01]]}}
    path = tmp_path / "dup.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection",
                                "features": [line, {**line, "properties": {"id": "B"}}]}))
    with pytest.raises(ConfigError, match="nothing written"):
        import_network(path, tmp_path / "net")
    assert not (tmp_path / "net").exists()
