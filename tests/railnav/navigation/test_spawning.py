"""New hypotheses from the fixes when no live hypothesis agrees with them
(`railnav.navigation.spawning`): the disagreement statistic in closed form; a start on the
wrong parallel track and a start 169 m along the track from the truth, on the real Brussels
excerpt (carrier-fixed fixes), recover; consistent runs spawn nothing (and the run with
dirty fixes keeps its netelements)."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from railnav.config import NavigatorConfig
from railnav.evaluation.netelement_truth import (
    collapse,
    netelement_scores,
    netelement_truth,
    route_passes,
)
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.navigation.hypotheses import hypothesis
from railnav.navigation.network_config import NetworkNavConfig
from railnav.navigation.net_tracks import OrientedTracks, bare
from railnav.navigation.network_weights import ecef_points, track_points_of
from railnav.navigation.spawning import fix_disagreement
from railnav.simulation.switch_network import SwitchNetworkSpec, switch_network
from trackmodel.earth import C_n_e, ecef_to_geodetic, geodetic_to_ecef

REPO = Path(__file__).resolve().parents[3]
EXCERPTS = REPO / "data" / "fixes" / "brussels"
NO_SPAWN = NetworkNavConfig(spawn=False)       # the test runs, no spawn
SPAWN = NetworkNavConfig()                     # the default spawns


def test_disagreement_is_the_horizontal_mahalanobis_distance():
    """A fix `a` m along and `c` m across the track from a hypothesis's point: d² =
    a²/(σ_e² + σ_s²) + c²/(σ_e² + σ_c²) for a fix covariance σ_e² I (east/north, here
    rotated onto the track's axes, which leaves it σ_e² I)."""
    net = switch_network(SwitchNetworkSpec(loops=1))
    tracks = OrientedTracks(net)
    config = NavigatorConfig(filter="gnss-only")
    pieces = bare("A0", 1)
    filt = GnssOnlyFilter(tracks.placed(pieces), config)
    s, sigma_s, sigma_e, sigma_c = 60.0, 3.0, 0.5, 1.5
    x = np.zeros(filt.layout.size)
    x[filt.layout.index("s")] = s
    P = np.eye(filt.layout.size)
    P[filt.layout.index("s"), filt.layout.index("s")] = sigma_s ** 2
    h = hypothesis(tracks, pieces, x, P, 0.0, filt)
    p = filt.track.at(s)
    t = np.asarray(p.u_n, dtype=float)[:2]
    t = t / np.linalg.norm(t)
    c_dir = np.array([-t[1], t[0]])
    a, c = 4.0, -2.5
    offset = np.r_[a * t + c * c_dir, 0.0]
    r0 = np.asarray(geodetic_to_ecef(float(p.lat), float(p.lon), 0.0), dtype=float).reshape(3)
    lat, lon, _ = ecef_to_geodetic(r0 + C_n_e(float(p.lat), float(p.lon)) @ offset)
    fixes = SimpleNamespace(lat=np.array([float(lat)]), lon=np.array([float(lon)]),
                            cov_n_m2=np.array([np.diag([sigma_e ** 2] * 3)]))
    d2 = fix_disagreement(*ecef_points(track_points_of([h])), np.array([sigma_s]), fixes, 0,
                          sigma_c)
    expected = a ** 2 / (sigma_e ** 2 + sigma_s ** 2) + c ** 2 / (sigma_e ** 2 + sigma_c ** 2)
    # the statistic's east/north are those at the fix, the track's tangent the one at the
    # point: frames a few metres apart on the ellipsoid differ by ~d/R ≈ 1e-6 rad
    assert d2[0] == pytest.approx(expected, rel=1e-5)


@pytest.fixture(scope="module")
def brussels():
    from railnav.jobs.run import read_sensor_files
    from trackmodel.network_io import read_network
    network = read_network(REPO / "data" / "networks" / "brussels_airport")
    data, config = read_sensor_files(fixes_path=EXCERPTS / "log_28876_L36-B_excerpt.csv")
    tab = data.fixes.table
    truth = netelement_truth(network, np.radians(tab["lat_deg"]), np.radians(tab["lon_deg"]))
    truth[tab["quality"].to_numpy() != "rtk_fixed"] = None
    t = tab["gps_time_s"].to_numpy() - data.start_gps_time_s
    return network, data, config, truth, t


def _scores(run, truth, t, after_s: float):
    cyc = run.cycles
    late = t > after_s
    return netelement_scores(cyc["time_s"], cyc["netelement"], cyc["netelement_probability"],
                             t[late], truth[late])


def test_a_start_on_the_wrong_parallel_track_recovers(brussels):
    """Told to start on 88_L_2016, 5.6 m abreast of the train's 88_L_3842, with no
    hypothesis abreast of it (``start_abreast_probability=0``): without spawns the fix-only
    filter stays on it with P = 1 until 2016 joins 5900 at 22 s (its cross-track row is
    widened by the map's 1.5 m; the fixes' 3 cm never move it off its element): wrong at
    every unambiguous epoch on 3842 after 3 s. With spawns, one spawn within the first
    window (5 fixes, 2 s) and the netelement is right at every unambiguous epoch after 3 s,
    as the run with no start given is."""
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    network, data, config, truth, t = brussels
    start = NetworkStart("88_L_2016")
    alone = {"start_abreast_probability": 0.0}
    stuck = navigate_network(network, data, config, start=start,
                             nav=replace(NO_SPAWN, **alone))
    assert stuck.spawns == ()
    on_3842 = np.array([e == "88_L_3842" for e in truth])
    bad = _scores(stuck, np.where(on_3842, truth, None), t, 3.0)
    assert bad["epochs"] >= 5 and bad["share_right"] == 0.0
    run = navigate_network(network, data, config, start=start, nav=replace(SPAWN, **alone))
    assert len(run.spawns) == 1 and run.spawns[0][0] <= 2.0
    sc = _scores(run, truth, t, 3.0)
    assert sc["epochs"] >= 90 and sc["share_right"] == 1.0
    est = run.estimates                     # the test's outcome is estimates.csv's status
    at = est["time_s"].round(6)
    assert (est.loc[at == round(run.spawns[0][0], 6), "status"] == "lost").all()
    assert (est.loc[at < run.spawns[0][0] - 1e-6, "status"] == "degraded").all()  # filling
    assert run.combined().statistics()["monitor"]["epochs"]["lost"] == 1   # summary.json
    route = run.route_frame()
    assert route["netelement"].iloc[0] == "88_L_2016"     # where it said it was, then
    assert route_passes(network, list(zip(route["netelement"][1:], route["orientation"][1:])),
                        collapse(truth))["passes_truth"]


def test_a_wrong_parallel_start_keeps_the_track_abreast(brussels):
    """The same wrong start with its abreast netelements (the default
    `NetworkNavConfig.start_abreast_probability`, `railnav.navigation.network_start.
    with_abreast`) and no spawns: 88_L_3842 gets a hypothesis at the start, the fixes'
    evidence decides, and the netelement is right at every unambiguous epoch (the RTK
    truth), from the first, with nothing spawned; the route is the one of the run with no
    start given (second method)."""
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    network, data, config, truth, t = brussels
    run = navigate_network(network, data, config, start=NetworkStart("88_L_2016"),
                           nav=NO_SPAWN)
    assert run.spawns == ()
    assert set(run.element_probability[0]) >= {"88_L_2016", "88_L_3842"}
    sc = _scores(run, truth, t, 0.0)
    assert sc["epochs"] >= 100 and sc["share_right"] == 1.0
    untold = navigate_network(network, data, config, nav=NO_SPAWN)
    assert run.route_frame()["netelement"].tolist() == \
        untold.route_frame()["netelement"].tolist()


def test_a_start_far_along_the_track_recovers(brussels):
    """Told to start at 400 m on the right element, 169 m from the train: without spawns
    its fixes are rejected and the estimate is more than 100 m off (500 m at the end: a
    jump back at 17 s leaves the speed wrong); with them the netelements and offsets after
    3 s equal the run with no start given (second method), the offsets within 0.5 m."""
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    network, data, config, truth, t = brussels
    start = NetworkStart("88_L_3842", offset_m=400.0)
    reference = navigate_network(network, data, config)
    stuck = navigate_network(network, data, config, start=start, nav=NO_SPAWN)
    run = navigate_network(network, data, config, start=start, nav=SPAWN)
    assert len(run.spawns) == 1
    ref = reference.cycles.set_index(reference.cycles["time_s"].round(6))
    for r, worst in ((stuck, None), (run, 0.5)):
        c = r.cycles.set_index(r.cycles["time_s"].round(6))
        common = c.index[c.index > 3.0].intersection(ref.index)
        assert common.size >= 100
        same = c.loc[common, "netelement"] == ref.loc[common, "netelement"]
        err = np.abs(c.loc[common, "netelement_offset_m"] - ref.loc[common, "netelement_offset_m"])
        if worst is None:
            assert float(err[common < 16.0].min()) > 100.0 and float(err.max()) > 400.0
        else:
            assert same.all() and float(err.max()) < worst


def test_consistent_runs_spawn_nothing_and_dirty_fixes_change_no_netelement(brussels):
    """No start given on the carrier-fixed excerpt: no spawn. On log 29083's excerpt
    (single-point and dead-reckoned fixes 90-200 m off the track beyond their σ) the test
    fires (22 epochs), but the network itself does not explain those windows
    (`Spawner._on_network`): no spawn (three, at 12.0, 36.8 and 47.2 s, before that rule),
    the status is not ``lost`` (it was on those 22: issue 14) and the per-epoch netelement
    is the one of the run without spawns at every cycle."""
    from railnav.jobs.run import read_sensor_files
    from railnav.navigation.network_navigator import navigate_network
    network, data, config, _, _ = brussels
    clean = navigate_network(network, data, config, nav=SPAWN)
    assert clean.spawns == ()
    est = clean.estimates
    assert (est.loc[est["time_s"] > 2.0, "status"] == "ok").all()
    dirty, cfg = read_sensor_files(fixes_path=EXCERPTS / "log_29083_L36-A_excerpt.csv")
    a = navigate_network(network, dirty, cfg, nav=SPAWN)
    b = navigate_network(network, dirty, cfg, nav=NO_SPAWN)
    assert b.spawns == () and a.spawns == ()
    fired = a.status_records["p_fix"].to_numpy(dtype=float) < SPAWN.spawn_p_value
    assert fired.sum() >= 10                                    # the test did fire
    assert (a.estimates["status"] != "lost").all()
    assert len(a.cycles) == len(b.cycles)
    assert (a.cycles["netelement"].to_numpy() == b.cycles["netelement"].to_numpy()).all()


def test_spawn_config_checks():
    from railnav.errors import ConfigError
    for bad in ({"spawn_window_epochs": -1}, {"spawn_window_epochs": 2.5},
                {"spawn_p_value": 0.0}, {"spawn_probability": 1.0}):
        with pytest.raises(ConfigError):
            NetworkNavConfig(**bad)


def test_runs_without_fixes_or_single_point_fixes_never_spawn():
    """A run with neither position fixes nor its GNSS epochs' single-point fixes
    (`railnav.navigation.spp_epochs`; GNSS runs: `tests/railnav/navigation/
    test_spp_epochs.py`) has no test to spawn from: the spawner is idle and returns the
    hypotheses it is given, whatever the epoch."""
    from railnav.navigation.spawning import Spawner
    spawner = Spawner(SPAWN, SimpleNamespace(fixes=None, schedule=None), 1.5,
                      start=lambda after_s: (_ for _ in ()).throw(AssertionError("started")))
    hyps = [object()]
    assert not spawner.active
    assert spawner.after_epoch(hyps, 3, 10.0) is hyps and spawner.records == []


def test_no_spawn_from_a_dead_reckoned_fix():
    """A window that fails at a dead-reckoned fix (the receiver's own extrapolation) keeps
    filling; the next fix of GNSS quality while it still fails gets the attempt. Spy
    `start`: not called at the dead-reckoned fix (window untouched), called at the next."""
    from railnav.errors import ConfigError
    from railnav.navigation.spawning import Spawner
    calls = []

    def start(after_s):
        calls.append(after_s)
        raise ConfigError("no candidate")          # the attempt ends there either way

    class Fixes(SimpleNamespace):
        def __len__(self):
            return len(self.quality)

    fixes = Fixes(quality=np.array(["dead_reckoning", "single"], dtype=object),
                            lat=np.radians([50.9, 50.9]), lon=np.radians([4.46, 4.46]),
                            cov_n_m2=np.tile(np.eye(3), (2, 1, 1)))
    spawner = Spawner(SPAWN, SimpleNamespace(fixes=fixes, schedule=None), 1.5, start)
    spawner.window, spawner.shares, spawner.fixes_in_window = [40.0] * 5, [1.0] * 5, [0] * 5
    hyps = [object()]
    assert spawner._spawn(hyps, 10.0, 0) is hyps and calls == []
    assert spawner.window == [40.0] * 5                      # still filling, not restarted
    assert spawner._spawn(hyps, 10.4, 1) is hyps and calls == [pytest.approx(10.4 - 1e-3)]
    assert spawner.window == []                              # one attempt per window


def test_the_airport_tunnel_log_spawns_nothing():
    """The real log_28554 as given (whole, 606 fixes: into the airport tunnel, 293 of them
    ``PROPAGATED``, drifting 20-37 m off every element from 180 s): the window test fires
    at dead-reckoned fixes, yet nothing is spawned, and the route is a path the
    network allows that passes the netelements its carrier-fixed fixes name. Before the
    rule the run spawned once, at 238.8 s from a ``PROPAGATED`` fix 24 m from 88_L_2013,
    and its route jumped there (not navigable)."""
    from railnav.jobs.run import read_sensor_files
    from railnav.navigation.network_navigator import navigate_network
    from trackmodel.network_io import read_network
    network = read_network(REPO / "data" / "networks" / "brussels_airport")
    data, config = read_sensor_files(fixes_path=EXCERPTS / "log_28554_L36-A_to_L36C-A.csv")
    run = navigate_network(network, data, config, nav=SPAWN)
    tab = data.fixes.table
    t_fix = tab["gps_time_s"].to_numpy() - data.start_gps_time_s
    records = run.status_records
    fired = records.loc[records["p_fix"] < SPAWN.spawn_p_value, "time_s"].to_numpy()
    k = np.searchsorted(t_fix, fired - 1e-6)
    assert (tab["quality"].to_numpy()[k] == "dead_reckoning").sum() >= 5   # the test fired
    assert run.spawns == ()
    truth = netelement_truth(network, np.radians(tab["lat_deg"]), np.radians(tab["lon_deg"]))
    truth[tab["quality"].to_numpy() != "rtk_fixed"] = None
    route = run.route_frame()
    check = route_passes(network, zip(route["netelement"], route["orientation"]),
                         collapse(truth))
    assert check["navigable"] and check["passes_truth"], check
