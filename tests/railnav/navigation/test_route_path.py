"""The route of a network run (`railnav.navigation.route_path`): a train standing at a
joint lists each element once, a train that goes 200 m into the next element and backs
out keeps A > B > A. References: the motion the fixes are written from (the route the
train truly took, and the network's own connections), not the navigator's output."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.gpstime import gps_time_s_to_utc_iso
from railnav.jobs.network import load_network, run_files_network
from railnav.navigation.route_path import EXCURSION_SIGMAS, PathEntry, entered, route
from railnav.simulation.switch_network import SwitchNetworkSpec, route_track, switch_network
from trackmodel.earth import C_n_e, ecef_to_geodetic

REPO = Path(__file__).resolve().parents[3]
BRUSSELS = REPO / "data" / "networks" / "brussels_airport"
START_GPS_TIME_S = 1_290_688_800.0
#: RTK-fixed fixes, as `railnav simulate --fixes-quality rtk_fixed=1` draws them, m and m/s.
SIGMA_FIX_M, SIGMA_UP_M, SIGMA_SPEED_MPS = 0.03, 0.05, 0.03


def _fixes(path: Path, line, t_s, s_m, v_mps, *, seed: int) -> Path:
    """A fix file of a train at ``s_m`` (speed ``v_mps`` along the line) on `line` at
    ``t_s``, each fix off by seeded white noise of the RTK-fixed σ."""
    rng = np.random.default_rng(seed)
    p = line.at(np.asarray(s_m, dtype=float))
    n = t_s.size
    e_n = rng.standard_normal((n, 3)) * [SIGMA_FIX_M, SIGMA_FIX_M, SIGMA_UP_M]
    lat, lon, h = ecef_to_geodetic(p.r_e + np.einsum("kij,kj->ki", C_n_e(p.lat, p.lon), e_n))
    v_n = p.u_n[:, :2] * np.asarray(v_mps, dtype=float)[:, None] + \
        rng.standard_normal((n, 2)) * SIGMA_SPEED_MPS
    gps = START_GPS_TIME_S + t_s
    pd.DataFrame({
        "gps_time_s": gps, "timestamp": gps_time_s_to_utc_iso(gps, suffix="Z"),
        "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon), "h_m": h,
        "speed_mps": np.hypot(v_n[:, 0], v_n[:, 1]),
        "course_deg": np.degrees(np.arctan2(v_n[:, 0], v_n[:, 1])) % 360.0,
        "sigma_east_m": np.full(n, SIGMA_FIX_M), "sigma_north_m": np.full(n, SIGMA_FIX_M),
        "sigma_up_m": np.full(n, SIGMA_UP_M), "cov_en_m2": np.zeros(n),
        "sigma_speed_mps": np.full(n, SIGMA_SPEED_MPS), "quality": ["rtk_fixed"] * n,
        "flag": ["rtk_fixed"] * n}).to_csv(path, index=False)
    return path


def _route(network, fixes: Path) -> list[str]:
    frame = run_files_network(network, fixes_path=fixes).network_result.route_frame()
    return list(frame["netelement"])


def test_standing_at_a_joint_lists_each_element_once(tmp_path):
    """10 min standing 3 mm past the joint of 88_L_155 and 88_L_111, on 88_L_111 (the
    simulated run that listed the two five times over in 12 s stood there; the mean
    crosses the joint hundreds of times): the route names each element once, and nothing
    but 88_L_111 and the elements joined to it at that end (the network's connections;
    3 mm from the joint with fixes of σ 3 cm, either side is right)."""
    network = load_network(BRUSSELS)
    line = network.route_track([("88_L_111", -1)])     # from its last coordinate
    t = np.arange(0.0, 601.0, 1.0)
    fixes = _fixes(tmp_path / "fixes.csv", line, t, np.full(t.size, 0.003),
                   np.zeros(t.size), seed=1)
    names = _route(network, fixes)
    joined = {e for e, _ in network.successors("88_L_111", 1)} | \
        {e for e, _ in network.predecessors("88_L_111", -1)}
    assert joined and "88_L_111" not in joined
    assert names and len(names) == len(set(names)), names
    assert set(names) <= {"88_L_111"} | joined, names


def test_a_reversal_keeps_both_visits(tmp_path):
    """On the simulated double line (`railnav.simulation.switch_network`, one loop): a
    train 100 m before the end of A0 runs 300 m on (200 m into A1, past the switch to
    A1 or L0) and backs to where it started, ``s = s0 + D sin²(πt/T)``: the route is
    A0 > A1 > A0."""
    network = switch_network(SwitchNetworkSpec(loops=1))
    line = route_track(network, [("A0", 1), ("A1", 1)])
    s0_m, depth_m, period_s = network.length_m("A0") - 100.0, 300.0, 120.0
    t = np.arange(0.0, period_s + 0.5, 1.0)
    s = s0_m + depth_m * np.sin(np.pi * t / period_s) ** 2
    v = depth_m * np.pi / period_s * np.sin(2.0 * np.pi * t / period_s)
    fixes = _fixes(tmp_path / "fixes.csv", line, t, s, v, seed=2)
    assert _route(network, fixes) == ["A0", "A1", "A0"]


def test_route_takes_out_only_shallow_excursions():
    """`route` on written paths: a visit between two visits to one element goes when it
    never went `EXCURSION_SIGMAS` σ_s deep, stays when it did; a path without a return
    is as it was."""
    a, b, c = (PathEntry("A", 1, 0.0), PathEntry("B", 1, 1.0, 0.0, EXCURSION_SIGMAS - 0.1),
               PathEntry("A", 1, 2.0, 5.0, 0.5))
    assert route((a, b, c)) == (a,)
    deep = b._replace(depth_sigmas=EXCURSION_SIGMAS + 0.1)
    assert route((a, deep, c)) == (a, deep, c)
    assert route((a, b, c, b._replace(entry_time_s=3.0))) == (a, b._replace(entry_time_s=3.0))
    on = (a, b, PathEntry("C", 1, 2.0, 0.0, 0.1))
    assert route(on) == on
    assert math.isinf(route((a, b, c))[0].depth_sigmas)


class _Mean:
    """What `entered` reads of a hypothesis: where its mean is, σ_s, its path."""

    def __init__(self) -> None:
        self.path, self.P, self.spot = (), np.zeros((1, 1)), None

    def at(self, element: str, s_m: float, sigma_m: float) -> "_Mean":
        self.spot, self.P[0, 0] = (element, 1, s_m), sigma_m ** 2
        return self

    def where(self):
        return self.spot

    def index(self, name: str) -> int:
        return 0


def test_entered_keeps_the_deepest_visit_in_sigma_s():
    """The depth of a visit is the greatest ``|s − s_entry| / σ_s`` of its cycles: into B
    at 0.01 m, then 0.05 m at σ 0.02 m (2 σ), then 0.10 m at σ 0.06 m (1.5 σ: not
    deeper), then back on A (a new visit, 0 deep); the start is sure (inf)."""
    h = _Mean()
    entered(h.at("A", 10.0, 0.02), 0.0)
    for element, s_m, sigma_m, time_s in (("B", 0.01, 0.02, 1.0), ("B", 0.05, 0.02, 2.0),
                                          ("B", 0.10, 0.06, 3.0), ("A", 9.99, 0.02, 4.0)):
        entered(h.at(element, s_m, sigma_m), time_s)
    assert [(p.element, p.entry_time_s) for p in h.path] == [("A", 0.0), ("B", 1.0),
                                                              ("A", 4.0)]
    assert math.isinf(h.path[0].depth_sigmas)
    assert h.path[1].depth_sigmas == pytest.approx((0.05 - 0.01) / 0.02, rel=1e-12)
    assert h.path[2].depth_sigmas == 0.0
