"""Where a hypothesis's train is, element by element (`railnav.navigation.element_shares`),
on the hand-built double line with one passing loop (A0 -> A1 | L0 -> A2), against the
normal distribution's CDF (SciPy) at the stretch ends."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from railnav.config import NavigatorConfig
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation.element_shares import element_shares
from railnav.navigation.hypotheses import hypothesis
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.simulation.switch_network import SwitchNetworkSpec, switch_network

TRACKS = OrientedTracks(switch_network(SwitchNetworkSpec(loops=1)))
CONFIG = NavigatorConfig(filter="gnss-only")


def _hyp(element: str, s: float, sigma: float, path: tuple):
    pieces = bare(element, 1)
    filt = GnssOnlyFilter(TRACKS.placed(pieces), CONFIG)
    x = np.zeros(filt.layout.size)
    x[filt.layout.index("s")], x[filt.layout.index("v")] = s, 15.0
    P = np.eye(filt.layout.size)
    P[filt.layout.index("s"), filt.layout.index("s")] = sigma ** 2
    return hypothesis(TRACKS, pieces, x, P, 0.0, filt, path)


def _by_element(parts) -> dict:
    out: dict = {}
    for e, _, p, _ in parts:
        out[e] = out.get(e, 0.0) + p
    return out


def test_a_way_just_past_the_switch_holds_the_mass_before_it_on_the_element_it_left():
    """A child on A1 0.35 m past the switch at A0's end, σ_s 1.5 m: Φ(−0.35/1.5) of it on
    A0 (at A0's end), the rest on A1 (its far end 489 m away: nothing beyond)."""
    h = _hyp("A1", 0.35, 1.5, (("A0", 1, 0.0), ("A1", 1, 10.0)))
    parts = element_shares(h, TRACKS)
    got = _by_element(parts)
    assert got["A0"] == pytest.approx(norm.cdf(-0.35 / 1.5), abs=1e-12)
    assert got["A1"] == pytest.approx(norm.cdf(0.35 / 1.5), abs=1e-12)
    assert [x for e, _, _, x in parts if e == "A0"] == [pytest.approx(200.0)]


def test_the_mass_beyond_a_switch_goes_to_its_ways_evenly():
    """On A0 0.3 m before its end (200 m), σ_s 1.5 m: ``1 − Φ(0.3/1.5)`` beyond, half on
    A1 and half on L0 (at their starts); a start (no path) keeps what lies before 0."""
    h = _hyp("A0", 199.7, 1.5, (("A0", 1, 0.0),))
    parts = element_shares(h, TRACKS)
    got = _by_element(parts)
    beyond = norm.sf(0.3 / 1.5)
    assert got["A1"] == pytest.approx(beyond / 2, abs=1e-12)
    assert got["L0"] == pytest.approx(beyond / 2, abs=1e-12)
    assert got["A0"] == pytest.approx(1.0 - beyond, abs=1e-12)
    assert sorted(x for e, _, _, x in parts if e != "A0") == [0.0, 0.0]


def test_a_buffer_stop_and_a_start_keep_their_mass():
    """A2 ends at a buffer stop and this hypothesis started on it: all on A2."""
    h = _hyp("A2", 399.0, 3.0, (("A2", 1, 0.0),))
    assert _by_element(element_shares(h, TRACKS)) == {"A2": pytest.approx(1.0, abs=1e-15)}
