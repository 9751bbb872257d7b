"""A network run's start on a known netelement and the netelements abreast of it
(`railnav.navigation.network_start.with_abreast`): the abreast hypotheses' positions and
prior weights in closed form, and a GNSS run told the wrong one of two straight parallel
tracks, whose true track's probability at the end is bounded below by the evidence that
the satellite geometry alone guarantees."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from railnav.config import NavigatorConfig
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation.hypotheses import hypothesis, normalized_weights
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.navigation.network_config import NetworkNavConfig
from railnav.navigation.network_start import with_abreast
from railnav.navigation.network_weights import ecef_points, track_points_of
from railnav.navigation.route_path import PathEntry
from railnav.simulation.switch_network import SwitchNetworkSpec, switch_network

CONFIG = NavigatorConfig(filter="gnss-only")


def _told(net, element: str, s: float):
    """A GNSS-only hypothesis on `element` at `s` and its filter factory."""
    tracks = OrientedTracks(net)

    def factory(pieces):
        return GnssOnlyFilter(tracks.placed(pieces), CONFIG)
    filt = factory(bare(element, 1))
    x = np.zeros(filt.layout.size)
    x[filt.layout.index("s")], x[filt.layout.index("v")] = s, 20.0
    return tracks, factory, hypothesis(tracks, bare(element, 1), x, np.eye(x.size), 0.0, filt,
                                       (PathEntry(element, 1, 0.0),))


@pytest.mark.parametrize("p", [0.01, 0.2])
def test_the_track_abreast_starts_beside_the_told_one_with_its_prior(p):
    """Told B of the double line 100 m into the lead-in: A0 (4.5 m to its right) gets a
    hypothesis at the point abreast (3-D distance = the spacing, the same tangent, ``v``
    kept), and the two carry 1 − p and p."""
    spec = SwitchNetworkSpec(loops=1)
    net = switch_network(spec)
    tracks, factory, told = _told(net, "B", 100.0)
    hyps = with_abreast([told], net, tracks, factory, NetworkNavConfig(
        start_abreast_probability=p))
    assert [h.element for h in hyps] == ["B", "A0"]
    r_e, u_e = ecef_points(track_points_of(hyps))
    assert np.linalg.norm(r_e[1] - r_e[0]) == pytest.approx(spec.spacing_m, abs=1e-3)
    assert float(u_e[0] @ u_e[1]) == pytest.approx(1.0, abs=1e-9)
    assert hyps[1].x[hyps[1].index("v")] == told.x[told.index("v")]
    assert normalized_weights(hyps) == pytest.approx([1.0 - p, p], rel=1e-12)


def test_nothing_abreast_or_no_prior_keeps_the_told_start_alone():
    """p = 0, or the other track farther than the crossing radius (15 m > 10 m): the told
    hypothesis alone, its weight untouched."""
    net = switch_network(SwitchNetworkSpec(loops=1))
    tracks, factory, told = _told(net, "B", 100.0)
    assert with_abreast([told], net, tracks, factory,
                        NetworkNavConfig(start_abreast_probability=0.0)) == [told]
    wide = switch_network(SwitchNetworkSpec(loops=1, spacing_m=15.0))
    tracks, factory, told = _told(wide, "B", 100.0)
    assert with_abreast([told], wide, tracks, factory, NetworkNavConfig()) == [told]
    assert told.log_weight == 0.0


#: Lower bound's margin on the evidence, in its standard deviations (below).
Z_MARGIN = 4.0


def _snapshot_evidence(trip, spec, sigma_m: float) -> float:
    """Σ over epochs of ½‖P⊥ δ‖²/σ²: the Kullback–Leibler divergence between the
    pseudoranges on a track and on one ``d`` to its left, each epoch's along-track position
    and clock bias free (``δ_i = d e_i·n``, ``P⊥`` the projection off the columns
    ``e_i·t`` and 1, ``e`` the horizontal line-of-sight components from the simulator's
    elevation and azimuth, ``t``, ``n`` the straight track's tangent and left normal)."""
    az = math.radians(spec.azimuth_deg)
    t = np.array([math.sin(az), math.cos(az)])
    n = np.array([-t[1], t[0]])
    total = 0.0
    for _, sats in trip.gnss.satellites.groupby("gps_time_s"):
        el = np.radians(sats["elevation_deg"].to_numpy())
        sat_az = np.radians(sats["azimuth_deg"].to_numpy())
        e = np.stack([np.cos(el) * np.sin(sat_az), np.cos(el) * np.cos(sat_az)], axis=1)
        H = np.stack([e @ t, np.ones(el.size)], axis=1)
        delta = spec.spacing_m * (e @ n)
        r = delta - H @ np.linalg.lstsq(H, delta, rcond=None)[0]
        total += 0.5 * float(r @ r) / sigma_m ** 2
    return total


def test_a_gnss_run_told_the_wrong_parallel_track_ends_on_the_right_one():
    """Straight A0 and B 4.5 m apart, the train on A0 for 60 s at 20 m/s (curvy's sensors,
    σ_pr 3 m, GPS), the navigator told B. The log-likelihood ratio of A0 over B is at
    least the snapshot divergence K (`_snapshot_evidence`: the filters' dynamics only add
    to it) in expectation, with variance 2K (Gaussian rows); so with the prior p on A0
    the end probability of B is below ``(1 − p)/p · exp(−(K − 4√(2K)))`` (1.4e-7: B is
    pruned, as it is at ~1e-7, `NetworkNavConfig.prune_probability`). No crossing
    prior (ε = 0: the weights are the prior and the evidence alone). On main (B alone)
    P(A0) = 0."""
    from railnav.filters.protocol import make_filter
    from railnav.jobs.network import candidate_starts
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.scenarios import get_scenario
    from railnav.simulation.switch_network import route_track
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    spec = SwitchNetworkSpec(loops=1, lead_in_m=1500.0)
    net = switch_network(spec)
    line = route_track(net, [("A0", 1)])
    scenario = replace(get_scenario("curvy"), profile=constant_speed(20.0), duration_s=60.0,
                       outages=(), start_s=50.0, sigma_pseudorange_m=3.0)
    config = navigator_config_for(scenario, filter="constrained", systems="G")
    trip = simulate_trip(scenario, track=line, seed=1, systems="G")
    nav = NetworkNavConfig(spawn=False, crossing_rate_per_s=0.0)
    res = navigate_network(net, trip.sensor_data(), config, nav=nav,
                           start=NetworkStart("B", direction=1),
                           initial=candidate_starts(trip, config,
                                                    make_filter(line, config, None)),
                           near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])))
    K = _snapshot_evidence(trip, spec, scenario.sigma_pseudorange_m)
    assert K > 50.0                      # 66.5: ~1.1 nats an epoch, seven satellites
    p = nav.start_abreast_probability
    worst_llr = K - Z_MARGIN * math.sqrt(2.0 * K)
    p_b_max = (1.0 - p) / p * math.exp(-worst_llr)
    assert res.element_probability[-1].get("B", 0.0) <= p_b_max
    assert res.cycles["netelement"].iloc[-1] == "A0"


def _fix_at_point(track, s: float, sigma_m: float):
    """A fix (`railnav.navigation.spawning.fix_disagreement`'s fields) on `track` at `s`,
    σ per horizontal axis."""
    from types import SimpleNamespace
    p = track.at(s)
    return SimpleNamespace(lat=np.array([float(p.lat)]), lon=np.array([float(p.lon)]),
                           cov_n_m2=np.array([np.diag([sigma_m ** 2] * 3)])), 0


def test_no_track_abreast_where_the_start_fix_says_the_start_is_lost():
    """Told B at 100 m, σ_s 1 m (the hypothesis's P), a fix of σ 3 m per axis: on A0
    abreast of it, A0's hypothesis starts (d² = 0 at A0's point); at A0's 190 m (A0 is
    200 m long), 90 m along, d² = 90²/(3² + 1²) = 810 ≫ the χ²₂ quantile of the spawn
    p-value (27.6): A0 is not started, nor is B's hypothesis touched."""
    net = switch_network(SwitchNetworkSpec(loops=1))
    tracks, factory, told = _told(net, "B", 100.0)
    nav = NetworkNavConfig()
    a0 = net.elements["A0"]
    near = with_abreast([told], net, tracks, factory, nav, fix=_fix_at_point(a0, 100.0, 3.0))
    assert [h.element for h in near] == ["B", "A0"]
    _, _, told = _told(net, "B", 100.0)
    far = with_abreast([told], net, tracks, factory, nav, fix=_fix_at_point(a0, 190.0, 3.0))
    assert far == [told] and told.log_weight == 0.0


def test_a_gnss_start_seeds_the_banks_noise_scale():
    """A network run started from GNSS (no initial state: the first fix,
    `railnav.navigation.initialization.first_fix`), the receiver's σ 10× too small: the
    bank's scale at the first epoch is the start's factors (σ factors √ of the variance
    factors `first_fix` gives the same data), and the first fix's covariance carries them
    (`railnav.navigation.start_scatter`)."""
    from railnav.navigation.initialization import first_fix
    from railnav.navigation.network_navigator import navigate_network
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.scenarios import get_scenario
    from railnav.simulation.switch_network import route_track
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    spec = SwitchNetworkSpec(loops=1, lead_in_m=1500.0)
    net = switch_network(spec)
    line = route_track(net, [("A0", 1)])
    scenario = replace(get_scenario("curvy"), profile=constant_speed(20.0), duration_s=30.0,
                       outages=(), start_s=50.0)
    config = navigator_config_for(scenario, filter="constrained", systems="G")
    m = config.measurement
    config = replace(config, measurement=replace(m, sigma_pr_m=m.sigma_pr_m / 10.0,
                                                 sigma_rr_mps=m.sigma_rr_mps / 10.0))
    trip = simulate_trip(scenario, track=line, seed=2, systems="G")
    data = trip.sensor_data()
    fix = first_fix(data, config)
    pos, vel = fix.start_factors
    assert pos > 1.0 and vel > 1.0
    res = navigate_network(net, data, config, nav=NetworkNavConfig(spawn=False))
    rows = res.innovations
    first = rows[rows["epoch"] == rows["epoch"].min()]
    for kind, factor in (("pseudorange", pos), ("range_rate", vel)):
        scale = first.loc[first["kind"] == kind, "noise_scale"].to_numpy()
        assert scale.size and np.allclose(scale, math.sqrt(min(factor, 400.0)), rtol=1e-12)
