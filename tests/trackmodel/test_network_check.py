"""Network checks (`trackmodel.network_check`, issue 13): gaps, near misses, open ends,
duplicates, short netelements, kinks.

References: networks built from straight sections whose gaps, angles and lengths are set
in closed form, and the Brussels network, whose one digitizing artefact (the 57° kink at
the 6-m 88_L_5831, data/networks/README.md) must be the one kink found.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from trackmodel.network import END, START, Connection, Network
from trackmodel.network_check import GAP_ERROR_M, GAP_WARN_M, check_network
from trackmodel.network_io import read_network
from trackmodel.network_lines import reversed_track
from trackmodel.sections import Section
from trackmodel.track import Track

R_M = 6_378_137.0


def _straight(lat, lon, length_m, azimuth_deg):
    return Track.from_sections([Section(length_m, azimuth_deg)], lat=float(np.squeeze(lat)),
                               lon=float(np.squeeze(lon)))


T = _straight(math.radians(50.0), math.radians(4.0), 1000.0, 0.0)


def _east_of_end(metres: float, length_m: float = 500.0, azimuth_deg: float = 0.0) -> Track:
    lat, lon, _ = T.geodetic(1000.0)
    return _straight(lat, lon + metres / (R_M * math.cos(float(lat[0]))), length_m, azimuth_deg)


def _levels(findings, where_part: str) -> list[str]:
    return [f.level for f in findings if where_part in f.where]


@pytest.mark.parametrize("gap_m, level", [(0.5 * GAP_WARN_M, None),
                                          (1.5 * GAP_WARN_M, "warning"),
                                          (2.0 * GAP_ERROR_M, "error")])
def test_gap_at_a_joint(gap_m, level):
    net = Network({"T": T, "S": _east_of_end(gap_m)}, [Connection("T", END, "S", START)])
    found = [f for f in check_network(net) if f.where == "T[1]-S[0]"]
    assert [f.level for f in found] == ([] if level is None else [level])
    if level is not None:
        assert f"{gap_m:.1f}" in found[0].what


def test_near_miss_and_open_ends():
    net = Network({"T": T, "S": _east_of_end(0.8)}, [])
    found = check_network(net)
    near = [f for f in found if "not connected" in f.what]
    assert len(near) == 2 and "0.80 m from" in near[0].what             # each way round
    summary = [f for f in found if f.where == "network"]
    assert len(summary) == 1 and summary[0].what.startswith("4 unconnected end(s)")
    apart = Network({"T": T, "S": _east_of_end(5.0)}, [])
    assert not [f for f in check_network(apart) if "not connected" in f.what]


def test_duplicates_either_way_round_but_not_a_parallel_track():
    net = Network({"T": T, "U": reversed_track(T), "P": _straight(
        math.radians(50.0), math.radians(4.0) + 4.5 / (R_M * math.cos(math.radians(50.0))),
        1000.0, 0.0)}, [])
    errors = [f for f in check_network(net) if f.level == "error"]
    assert [f.where for f in errors] == ["T, U"] and "duplicates" in errors[0].what


def test_short_netelement_and_a_sharp_navigable_kink():
    short = _east_of_end(0.0, length_m=0.3)
    sharp = _east_of_end(0.0, azimuth_deg=40.0)
    net = Network({"T": T, "Q": short, "K": sharp},
                  [Connection("T", END, "Q", START), Connection("T", END, "K", START),
                   Connection("Q", START, "K", START, "none")])
    found = check_network(net)
    assert [f.level for f in found if f.where == "Q"] == ["warning"]
    kinks = [f for f in found if "kink" in f.what]
    assert [f.where for f in kinks] == ["T[1]-K[0]"] and "40.0°" in kinks[0].what


def test_brussels_has_its_one_artefact():
    net = read_network(Path(__file__).resolve().parents[2] / "data" / "networks"
                       / "brussels_airport")
    found = check_network(net)
    assert not [f for f in found if f.level == "error"]
    kinks = [f for f in found if "kink" in f.what]
    assert len(kinks) == 1 and "88_L_5831" in kinks[0].where and "57.2°" in kinks[0].what
