"""A study whose track is a route through a network (issue 13): ``NETWORK:E1,E2,...``.

References: the route's line as `trackmodel.network_routes.route_track` gives it (the run's
track must be that line), and the study's own located errors for a bad route.
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.studies.file import parse_study_config
from railnav.studies.runs import expand_grid, run_one
from trackmodel.io import parse_track_text
from trackmodel.network_io import read_network
from trackmodel.network_routes import route_track
from tests.conftest import DATA

ROUTE = "88_L_111,88_L_154,88_L_7815"
TEXT = f"""[study]
name = "route"
replicates = 1
duration_s = 20.0
[grid]
track = "brussels_airport:{ROUTE}"
imu_grade = "tactical"
filter = "constrained"
outage_start_s = 5.0
outage_duration_s = 5.0
"""


def test_study_runs_on_a_network_route(tmp_path):
    config = parse_study_config(TEXT, path=tmp_path / "s.toml")
    (spec,) = expand_grid(config)
    track = parse_track_text(spec.track_text)
    line = route_track(read_network(DATA / "networks" / "brussels_airport"), ROUTE)
    s = np.linspace(0.0, line.length_m, 200)
    assert np.max(np.linalg.norm(track.at(s).r_e - line.at(s).r_e, axis=1)) < 1e-3
    row = run_one(spec)
    assert row["status"] == "ok", row["error"]
    assert row["track"] == f"brussels_airport:{ROUTE}"


@pytest.mark.parametrize("track, words", [
    ("brussels_airport:88_L_111,nope", "no netelement 'nope'"),
    ("nowhere:88_L_111", "network 'nowhere' not found"),
    ("nothing.csv", "not found"),
])
def test_bad_route_track_is_a_located_error(tmp_path, track, words):
    with pytest.raises(ConfigError, match=words) as info:
        parse_study_config(TEXT.replace(f"brussels_airport:{ROUTE}", track),
                           path=tmp_path / "s.toml")
    assert "grid.track" in str(info.value) or "s.toml" in str(info.value)
