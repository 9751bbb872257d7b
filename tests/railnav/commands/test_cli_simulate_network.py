"""``railnav simulate --network N --route E1,E2`` (issue 13): a trip simulated on a route's
line, and that line written for ``railnav run``.

References: the route's line of `trackmodel.network_routes.route_track` (the truth must lie
on it, and on the netelements within the fit tolerance), and the track file read back.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from trackmodel.io import read_track
from trackmodel.network_io import read_network
from trackmodel.network_routes import route_track

NETWORKS = Path(__file__).resolve().parents[3] / "data" / "networks"
BRUSSELS = NETWORKS / "brussels_airport"
ROUTE = "88_L_111,88_L_154,88_L_7815"
FIT_TOL_M = 0.5


def test_simulate_on_a_route(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["-q", "simulate", "--network", str(BRUSSELS), "--route", ROUTE,
                 "--scenario", "curvy", "--duration-s", "60", "--no-gnss",
                 "--out", str(out)]) == 0
    net = read_network(BRUSSELS)
    line = route_track(net, ROUTE)
    written = read_track(out / "route_track.csv")
    assert written.length_m == pytest.approx(line.length_m, abs=1e-6)
    truth = pd.read_csv(out / "truth.csv")
    lat, lon = np.radians(truth["lat_deg"]), np.radians(truth["lon_deg"])
    on_line = line.project(lat.to_numpy(), lon.to_numpy())
    assert np.max(np.abs(on_line.cross_track_m)) < 1e-3
    assert truth["s_m"].max() > 300.0                          # it went somewhere
    near = net.project(lat.to_numpy()[::50], lon.to_numpy()[::50], radius_m=5.0)
    best = near.groupby("point")["distance_m"].min()
    assert len(best) == len(lat[::50]) and best.max() <= FIT_TOL_M
    meta = json.loads((out / "scenario.json").read_text())
    assert meta["track"].endswith(":-88_L_111>-88_L_154>-88_L_7815")


@pytest.mark.parametrize("argv, message", [
    (["--route", ROUTE], "--network and --route go together"),
    (["--network", str(BRUSSELS)], "--network and --route go together"),
    (["x.csv", "--network", str(BRUSSELS), "--route", ROUTE], "not both"),
    (["--network", str(BRUSSELS), "--route", "88_L_111,nope"],
     "--route 'nope': no such netelement"),
])
def test_bad_flags_are_one_line(tmp_path, capsys, argv, message):
    out = tmp_path / "sim"
    assert main(["-q", "simulate", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not out.exists()
