"""A network hypothesis at a buffer stop leaves by the single-track runs' rule
(`railnav.navigation.loop.TrackEndWatch`, one per hypothesis): one whose vehicle turns
round a few metres past the stop lives on, one that drives off dies.

References: a hand-made truth on a 600-m straight (forwards, a stop, backwards: the
single-track model test, ``tests/railnav/filters/test_gnss_only_filter.py``), fixes
simulated on it (`railnav.simulation.fixes.simulate_fixes`, seeded), and a one-element
network whose element is the straight cut short of where the truth turns or drives on.
"""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

from railnav.config import NavigatorConfig
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation import loop
from railnav.navigation.hypotheses import hypothesis, rebased
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.navigation.network_navigator import navigate_network
from railnav.sensor_data import SensorData
from railnav.simulation.fixes import FixSimConfig, simulate_fixes
from railnav.simulation.switch_network import SwitchNetworkSpec, switch_network
from trackmodel.network import Network
from trackmodel.origin import Origin
from trackmodel.sections import Section
from trackmodel.track import Track

START_GPS_S = 1.3e9
ORIGIN = Origin(45.0, 7.0, 250.0)
LINE = Track([Section(600.0, 90.0, 0.3)], ORIGIN)
S0_M = 200.0
#: |error| <= this many σ for every estimate (as the single-track model test).
MAX_SIGMAS = 4.5


def _run(monkeypatch, s_of_t, v_of_t, duration_s: float, element_m: float, seed: int):
    """The network run of fixes (single-point class, σ 2.5 m, 1 Hz) of the truth ``s(t)``
    on `LINE`, on the network of `LINE`'s first `element_m`; the result, the truth's
    times and ``s``, and every `beyond_track` record the run's end watches saw."""
    t = np.arange(0.0, duration_s + 1e-9, 0.1)
    s, v = s_of_t(t), v_of_t(t)
    p = LINE.at(s)
    truth = types.SimpleNamespace(time_s=t, lat=p.lat, lon=p.lon, r_e=p.r_e,
                                  v_n=v[:, None] * p.u_n)
    fixes = simulate_fixes(truth, start_gps_time_s=START_GPS_S,
                           config=FixSimConfig(quality_mix=(("single", 1.0),)),
                           rng=np.random.default_rng(seed))
    network = Network({"stub": Track([Section(element_m, 90.0, 0.3)], ORIGIN)}, [])
    hits, one_epoch = [], loop.beyond_track

    def beyond(*args):
        record = one_epoch(*args)
        if record is not None:
            hits.append(record)
        return record
    monkeypatch.setattr(loop, "beyond_track", beyond)
    run = navigate_network(network, SensorData(START_GPS_S, fixes=fixes),
                           NavigatorConfig(filter="gnss-only"))
    return run, t, s, hits


@pytest.mark.parametrize("seed", [1, 2])
def test_a_hypothesis_that_turns_round_4_m_past_a_buffer_stop_lives_on(seed, monkeypatch):
    """The truth runs 4 m past the element's end (σ_s ~0.9 m there), stops and comes
    back. The hypothesis's state does go beyond the end by 3σ_s while moving away by
    3σ_v (`beyond_track` alone killed it at 17-18 s, seeds 1-3, and the run started
    again from the next fix), yet it lives to the end of the drive, the estimates'
    ``s`` within their bound."""
    duration_s, speed_mps = 40.0, 5.0
    reach_m = speed_mps * duration_s / math.pi               # s0 + V T/π: where it turns
    run, t, s, hits = _run(
        monkeypatch, lambda t: S0_M + reach_m * np.sin(math.pi * t / duration_s),
        lambda t: speed_mps * np.cos(math.pi * t / duration_s), duration_s,
        S0_M + reach_m - 4.0, seed)
    assert hits and all(h["end"] == "end" for h in hits)
    assert run.restarts == () and run.cycles["time_s"].iloc[-1] >= duration_s - 1e-6
    est = run.estimates
    s_true = np.interp(est["time_s"], t, s)
    assert np.all(np.abs(est["netelement_offset_m"] - s_true) <= MAX_SIGMAS * est["sigma_s_m"])


def test_a_hypothesis_that_drives_off_a_buffer_stop_dies(monkeypatch):
    """The truth drives on at 10 m/s past the end of the 300-m element: the hypothesis
    dies once it is beyond the end by 3σ_s, moving away, and has moved on by 3σ_s more,
    not before the truth is past the end and not long after; no fix is near the network
    after that, so the run ends there."""
    speed_mps, element_m = 10.0, 300.0
    run, t, s, hits = _run(monkeypatch, lambda t: S0_M + speed_mps * t,
                           lambda t: np.full_like(t, speed_mps), 35.0, element_m, seed=1)
    assert len(run.restarts) == 1
    died_s = run.restarts[0]
    truth_at_death_m = float(np.interp(died_s, t, s))
    travel_after_end_m = 10.0 * speed_mps        # 10 s at 10 m/s: σ_s is ~1 m
    assert element_m < truth_at_death_m < element_m + travel_after_end_m
    left = hits[-1]
    assert left["time_s"] == died_s
    assert left["s_m"] > element_m + loop.END_MARGIN_SIGMA * left["sigma_s_m"]
    assert run.cycles["time_s"].iloc[-1] <= died_s


def test_a_rebased_hypothesis_keeps_what_its_watch_has_seen():
    """A hypothesis on A1's tail chained to A2 (whose end is the buffer stop of the
    synthetic double line) is 5σ_s past that end and moving on: its watch's first check
    of the run returns None. Rebased onto A2 alone (its ``s`` less A1's stretch), the
    watch still measures travel from that check: 2σ_s on, it is kept; 4σ_s on, it has
    left. (Unshifted, the first check of the run would lie A1's stretch behind it.)"""
    spec = SwitchNetworkSpec(loops=1)
    tracks = OrientedTracks(switch_network(spec))
    last = f"A{2 * spec.loops}"
    pieces = (("A1", 1, tracks.network.length_m("A1") - 150.0),) + bare(last, 1)
    config = NavigatorConfig(filter="gnss-only")

    def make_child(parent, pieces):
        return GnssOnlyFilter(tracks.placed(pieces), config)
    filt = make_child(None, pieces)
    x = np.zeros(filt.layout.size)
    i_s, i_v = filt.layout.index("s"), filt.layout.index("v")
    length = filt.track.length_m
    x[i_s], x[i_v] = length + 5.0, 10.0                  # σ_s = σ_v = 1 (P = I)
    h = hypothesis(tracks, pieces, x, np.eye(filt.layout.size), 0.0, filt)
    assert h.end_watch.check(h.filt, h.x, h.P, 0.0) is None
    moved = rebased(h, tracks, make_child)
    assert moved.pieces == bare(last, 1) and moved.s_m == pytest.approx(length + 5.0 - 150.0)
    on = moved.x.copy()
    on[i_s] += 2.0
    assert moved.end_watch.check(moved.filt, on, moved.P, 1.0) is None
    on[i_s] += 2.0
    assert moved.end_watch.check(moved.filt, on, moved.P, 2.0) is not None
