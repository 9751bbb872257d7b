"""Each GNSS epoch's own single-point fix (`railnav.navigation.spp_epochs`), the spawn
test's fixes in GNSS network runs; and GNSS network runs that started wrong recover by
spawning from them.

References: the simulator's truth (antenna on the track point: curvy has no lever arm)
and its clock; the χ²₂ distribution of an honest horizontal error (a white error model:
the simulator draws white pseudorange errors of the σ the navigator is told); χ²'s
survival in closed form for the window's test (``e^{-x/2} Σ_{k<n} (x/2)^k / k!``).
"""
from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from railnav.config import NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation.hypotheses import hypothesis
from railnav.navigation.network_config import NetworkNavConfig
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.navigation.spawning import Spawner
from railnav.navigation.spp_epochs import correlation_s, epoch_spp_fixes
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.switch_network import SwitchNetworkSpec, switch_network
from trackmodel.earth import C_n_e, ecef_to_geodetic, geodetic_to_ecef


@pytest.fixture(scope="module")
def curvy_trip():
    from railnav.navigation.navigator import trip_samples
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    scenario = replace(get_scenario("curvy"), duration_s=200.0, outages=(),
                       sigma_pseudorange_m=3.0)
    trip = simulate_trip(scenario, seed=3, systems="G")
    config = navigator_config_for(scenario, systems="G")
    data = trip.sensor_data()
    return trip, data, config, trip_samples(data, config)


def test_fixes_are_the_truth_within_their_own_covariance(curvy_trip):
    """White pseudorange errors of the declared σ: the horizontal errors of the epochs'
    fixes against the truth, whitened by their own covariance, are χ²₂: mean 2 (its
    standard error 2/√N: 0.14 for 201 epochs; 4 of them allowed), and 1 % beyond the
    99 % quantile −2 ln 0.01 (binomial, ≤ 8 of 201 at 4σ); their mean error, east and
north, is within 4 σ of a mean of N white errors."""
    trip, data, config, samples = curvy_trip
    fixes = epoch_spp_fixes(samples.gnss, data, config)
    assert len(fixes) == len(samples.gnss.epochs) and np.isfinite(fixes.lat).all()
    assert (fixes.quality == "single").all()
    lat = np.interp(fixes.time_s, trip.truth.time_s, trip.truth.lat)
    lon = np.interp(fixes.time_s, trip.truth.time_s, trip.truth.lon)
    h = np.interp(fixes.time_s, trip.truth.time_s, trip.truth.h)
    r_fix = np.asarray(geodetic_to_ecef(fixes.lat, fixes.lon, fixes.h_m)).reshape(-1, 3)
    r_true = np.asarray(geodetic_to_ecef(lat, lon, h)).reshape(-1, 3)
    enu = np.einsum("kji,kj->ki", C_n_e(lat, lon).reshape(-1, 3, 3), r_fix - r_true)[:, :2]
    z2 = np.einsum("ki,kij,kj->k", enu, np.linalg.inv(fixes.cov_n_m2[:, :2, :2]), enu)
    n = z2.size
    assert abs(z2.mean() - 2.0) < 4 * 2.0 / math.sqrt(n)
    assert (z2 > -2 * math.log(0.01)).sum() <= 8
    sigma_mean = np.sqrt(np.mean(fixes.cov_n_m2[:, :2, :2].diagonal(axis1=1, axis2=2), 0) / n)
    assert np.all(np.abs(enu.mean(axis=0)) < 4 * sigma_mean)     # white: the mean's σ


def test_fixes_are_the_receivers_single_point_solutions(curvy_trip):
    """The same fixes as `gnss_obs.solve_spp` gives for the whole observation file (its
    table path: each epoch selected again, iterated to its default 1-mm tolerance from
    the previous fix, with DOPs, protection levels and sky): the extrapolated guess,
    the 30-m tolerance and no details (`gnss_obs.spp.solve_spp_epoch`'s
    ``details=False``) change the position by < 1e-4 m and not the covariance."""
    from gnss_obs.spp import solve_spp
    from railnav.navigation.track_fixes import spp_config_of
    _, data, config, samples = curvy_trip
    fixes = epoch_spp_fixes(samples.gnss, data, config)
    spp = solve_spp(data.obs, data.nav, spp_config_of(config))
    t = spp.gps_time_s - data.start_gps_time_s
    k = np.searchsorted(t, fixes.time_s)
    assert np.allclose(t[k], fixes.time_s, atol=1e-6)
    r_fix = np.asarray(geodetic_to_ecef(fixes.lat, fixes.lon, fixes.h_m)).reshape(-1, 3)
    assert np.max(np.linalg.norm(r_fix - spp.r_e[k], axis=1)) < 1e-4
    np.testing.assert_allclose(fixes.cov_n_m2, spp.cov_enu_m2[k], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("offset_m", [3.0, 10.0, 100.0])
def test_fixes_linearized_at_a_hypothesis(curvy_trip, offset_m):
    """Solved from the satellites a hypothesis's filter prepared at its prior
    (`EpochSppFixes.solve`'s ``linearized``: one least-squares step from there, no
    preparation of its own, when that step is below `TOL_M`), here a point `offset_m` in a
    random direction from `gnss_obs.solve_spp`'s fix: the corrections and weights are
    those of that point instead of the plain least-squares solution's, where `solve_spp`
    takes its last step (troposphere, ionosphere, Sagnac, elevation σ: gradients of order
    1e-3 per metre; the geometry's own linearization error δ²/(2ρ) is < 1e-5 m).
    What the spawn test needs: each fix within 1 % of its smallest horizontal σ of
    `solve_spp`'s (its ``d_h²`` then moves by < 2 % of ``d_h``) and its covariance
    within 1e-3; measured here < 8 mm and 3e-5. From beyond `TOL_M` (100 m) the fix is
    iterated as without a linearization: < 1e-4 m."""
    from gnss_obs.spp import solve_spp
    from railnav.navigation.spp_epochs import TOL_M, EpochSppFixes
    from railnav.navigation.track_fixes import spp_config_of
    _, data, config, samples = curvy_trip
    g = samples.gnss
    spp = solve_spp(data.obs, data.nav, spp_config_of(config))
    k_spp = np.searchsorted(spp.gps_time_s - data.start_gps_time_s, g.time_s)
    rng = np.random.default_rng(11)
    solver = EpochSppFixes.of(g, data, config)
    for k, j in enumerate(k_spp):
        step = rng.normal(size=3)
        r0 = spp.r_e[j] + offset_m * step / np.linalg.norm(step)
        solver.solve(k, (r0, g.prepare(k, r0)))
    fixes = solver.fixes
    assert np.isfinite(fixes.lat).all()
    r_fix = np.asarray(geodetic_to_ecef(fixes.lat, fixes.lon, fixes.h_m)).reshape(-1, 3)
    error_m = np.linalg.norm(r_fix - spp.r_e[k_spp], axis=1)
    if offset_m > TOL_M:
        assert np.max(error_m) < 1e-4
    sigma_min = np.sqrt(np.linalg.eigvalsh(fixes.cov_n_m2[:, :2, :2])[:, 0])
    assert np.all(error_m < 0.01 * sigma_min)
    np.testing.assert_allclose(fixes.cov_n_m2, spp.cov_enu_m2[k_spp], rtol=1e-3, atol=1e-9)


def test_no_epochs_no_fixes():
    assert epoch_spp_fixes(None, SimpleNamespace(nav=None), NavigatorConfig()) is None


def test_correlation_is_the_larger_of_the_declared_ones():
    assert correlation_s(NetworkNavConfig(), NavigatorConfig(pseudorange_correlation_s=0.0)) \
        == 0.0
    assert correlation_s(NetworkNavConfig(evidence_correlation_s=60.0),
                         NavigatorConfig()) == 60.0
    assert correlation_s(NetworkNavConfig(), NavigatorConfig()) == \
        NavigatorConfig().pseudorange_correlation_s == 20.0


def _chi2_sf_even(x: float, dof: int) -> float:
    """χ² survival for an even number of degrees of freedom, closed form."""
    half = x / 2.0
    return math.exp(-half) * sum(half ** k / math.factorial(k) for k in range(dof // 2))


def _spawner_across(cross_m: float, tau_s: float, calls: list):
    """A hand-built case: one hypothesis at s = 60 m on A0 (σ_s 3 m), and single-point
    fixes (σ 2 m per axis) `cross_m` across the track from it at each 1-s epoch; the
    spawner of a run without position fixes (`spp`, τ `tau_s`); `calls` collects the
    spawn attempts (which end at once)."""
    net = switch_network(SwitchNetworkSpec(loops=1))
    tracks = OrientedTracks(net)
    pieces = bare("A0", 1)
    filt = GnssOnlyFilter(tracks.placed(pieces), NavigatorConfig(filter="gnss-only"))
    x = np.zeros(filt.layout.size)
    x[filt.layout.index("s")] = 60.0
    P = np.eye(filt.layout.size)
    P[filt.layout.index("s"), filt.layout.index("s")] = 9.0
    h = hypothesis(tracks, pieces, x, P, 0.0, filt)
    p = filt.track.at(60.0)
    t = np.asarray(p.u_n, dtype=float)[:2] / np.linalg.norm(np.asarray(p.u_n)[:2])
    off = np.r_[cross_m * np.array([-t[1], t[0]]), 0.0]
    r0 = np.asarray(geodetic_to_ecef(float(p.lat), float(p.lon), 0.0), dtype=float).reshape(3)
    lat, lon, _ = ecef_to_geodetic(r0 + C_n_e(float(p.lat), float(p.lon)) @ off)
    n = 8

    class Fixes(SimpleNamespace):
        def __len__(self):
            return n

    spp = Fixes(time_s=np.arange(n, dtype=float), lat=np.full(n, float(lat)),
                lon=np.full(n, float(lon)), cov_n_m2=np.tile(np.diag([4.0, 4.0, 9.0]), (n, 1, 1)),
                quality=np.full(n, "single", dtype=object))
    schedule = SimpleNamespace(split=lambda epoch: (epoch, -1))

    def start(after_s):
        calls.append(after_s)
        raise ConfigError("no candidate")

    spawner = Spawner(NetworkNavConfig(), SimpleNamespace(fixes=None, schedule=schedule), 1.5,
                      start, spp=spp, spp_correlation_s=tau_s)
    return spawner, h


@pytest.mark.parametrize("tau_s", [0.0, 1e7])
def test_gnss_run_window_test_in_closed_form(tau_s):
    """Fixes 9 m across from the hypothesis: d² = 9²/(σ² + σ_c²) = 81/6.25 each epoch
    (σ 2 m, the map's σ_c 1.5 m). White (τ 0): the 5-epoch window is χ²₁₀ of 5 d²; errors
    as correlated as τ → ∞ (each later epoch counts ~0): one look, χ²₂ of the mean d²,
    ``e^{-d²/2}``. The first four epochs fill the window (``degraded``); the fifth is
    tested; below 1e-6 (white: 2e-9) the status is ``lost`` and a spawn is attempted from
    that epoch (``after_s`` just before it); above, ``degraded`` (τ → ∞: e^{-6.48} = 1.5e-3
    ≥ the monitor's 1e-3: ``ok``)."""
    calls: list = []
    spawner, h = _spawner_across(9.0, tau_s, calls)
    assert spawner.active
    d2 = 81.0 / (4.0 + 1.5 ** 2)
    for k in range(5):
        assert spawner.after_epoch([h], k, float(k)) == [h]
    statuses = [r[1] for r in spawner.records]
    assert statuses[:4] == ["degraded"] * 4
    p = spawner.records[4][2]
    expected = _chi2_sf_even(5 * d2, 10) if tau_s == 0.0 else math.exp(-d2 / 2.0)
    assert p == pytest.approx(expected, rel=1e-4)
    assert spawner.records[4][3] == pytest.approx(d2, rel=1e-4)
    if tau_s == 0.0:
        assert statuses[4] == "lost" and calls == [pytest.approx(4.0 - 1e-3)]
    else:
        assert statuses[4] == "ok" and calls == []


#: The simulated receiver clock's bias at the start of `wrong_start_runs`, m (100 µs).
CLOCK_BIAS0_M = 29_979.0


@pytest.fixture(scope="module")
def wrong_start_runs():
    """A GNSS network run (tactical IMU, constrained INS/GNSS, σ_pr 3 m, GPS, no fixes) on
    the double line, straight along A at 20 m/s, told to start on A0 400 m ahead of the
    truth (the truth brought onto A0, `railnav.jobs.network.candidate_starts`, then
    shifted): with spawning off and on; the time, clock index, state and covariance of
    each hypothesis a spawn started, as it started (spy)."""
    from railnav.filters.protocol import make_filter
    from railnav.jobs.network import candidate_starts
    from railnav.navigation import spawning
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.switch_network import loop_route, route_track
    from railnav.simulation import trip as trip_module
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    spec = SwitchNetworkSpec(loops=1)
    net = switch_network(spec)
    legs = loop_route(spec, [False])
    line = route_track(net, legs)
    scenario = replace(get_scenario("curvy"), profile=constant_speed(20.0), duration_s=25.0,
                       outages=(), start_s=50.0, sigma_pseudorange_m=3.0)
    config = navigator_config_for(scenario, systems="G")
    mp = pytest.MonkeyPatch()
    sim_config = trip_module.gnss_sim_config_for     # a receiver clock 100 µs off at start
    mp.setattr(trip_module, "gnss_sim_config_for", lambda *a, **k: replace(
        sim_config(*a, **k), clock_bias0_m=CLOCK_BIAS0_M))
    try:
        trip = simulate_trip(scenario, track=line, seed=2, systems="G")
    finally:
        mp.undo()
    base = candidate_starts(trip, config, make_filter(line, config, None))

    def initial(filt, element, orientation):
        init = base(filt, element, orientation)
        x0 = np.array(init.x0, dtype=float)
        x0[filt.layout.index("s")] += 400.0
        return replace(init, x0=x0)

    spawned = []
    original = spawning.Spawner._spawn

    def spy(self, hyps, time_s, f, *more):
        out = original(self, hyps, time_s, f, *more)
        spawned.extend((time_s, h.index("clock_bias"), h.x.copy(), h.P.copy())
                       for h in out[len(hyps):])
        return out

    runs = {}
    mp.setattr(spawning.Spawner, "_spawn", spy)
    try:
        for spawn in (False, True):
            runs[spawn] = navigate_network(
                net, trip.sensor_data(), config, nav=NetworkNavConfig(spawn=spawn),
                start=NetworkStart("A0", direction=1), initial=initial,
                near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])))
    finally:
        mp.undo()
    return trip, net, legs, runs, spawned


def _route_error_m(trip, net, legs, run):
    """The most probable hypothesis's distance along the route minus the truth's, per
    cycle (A's elements chained), m."""
    starts = dict(zip([e for e, _ in legs],
                      np.concatenate([[0.0], np.cumsum([net.length_m(e) for e, _ in legs])])))
    cyc = run.cycles
    truth_s = np.interp(run.time_s, trip.truth.time_s, trip.truth.s)
    return np.array([starts.get(e, np.nan) for e in cyc["netelement"]]) + \
        cyc["netelement_offset_m"].to_numpy() - truth_s


def test_a_gnss_run_started_400_m_ahead_recovers_by_spawning(wrong_start_runs):
    """Without spawning the run stays ~400 m ahead of the truth (its rows rejected, it
    dead-reckons: > 100 m off, or off the route, at every cycle up to 20 s; at 150 m the
    start's first update pulls it in part of the way, 35-70 m on seeds 1-4, and whether
    it converges is the draw's: `benchmarks/bench_network_spawn_gnss.py`); with it, one
    spawn once the
    5-epoch window has filled (by 5 s), and from 8 s on the most probable hypothesis is
    within 10 m of the truth along the route. The ``status`` column exists either way and
    says ``lost`` at the spawn."""
    trip, net, legs, runs, _ = wrong_start_runs
    off, on = (_route_error_m(trip, net, legs, runs[k]) for k in (False, True))
    t_off, t_on = runs[False].time_s, runs[True].time_s
    off = np.nan_to_num(off, nan=np.inf)                     # NaN: off the route
    assert runs[False].spawns == () and np.all(np.abs(off[t_off <= 20.0]) > 100.0)
    assert len(runs[True].spawns) == 1 and runs[True].spawns[0][0] <= 5.0 + 1e-6
    assert np.all(np.abs(on[t_on >= 8.0]) < 10.0)
    for run in runs.values():
        status = run.estimates["status"].to_numpy()
        assert set(status) <= {"ok", "degraded", "lost"}
    assert "lost" in set(runs[True].estimates["status"])


def test_spawned_hypotheses_start_with_the_single_point_clock(wrong_start_runs):
    """A spawn in a GNSS run starts its hypotheses as the network start does
    (`railnav.navigation.network_start`: ``filt.initial_from_fix`` of the epoch's
    single-point fix), clock included: each one's receiver clock bias is the simulator's
    true clock within 4 of its own σ (the filter's initial clock σ, 30 m; the SPP's
    clock error ~ σ_pr · TDOP, a few m). The simulated receiver clock starts
    `CLOCK_BIAS0_M` off (100 µs), so a clock not taken from the fix (0) is 1000 σ off."""
    trip, *_, spawned = wrong_start_runs
    assert spawned
    for time_s, i, x, P in spawned:
        bias_true, _ = trip.clock_truth(np.array([time_s]))
        assert abs(bias_true[0] - CLOCK_BIAS0_M) < 10.0       # the clock is where it was put
        assert abs(x[i] - bias_true[0]) < 4.0 * math.sqrt(P[i, i])
