"""Runs on a track network: which way did the train go at each switch?

A train starts at a known network position (`trackmodel.network.NetPosition`). Every way
it may go within a horizon is a *route* (`trackmodel.network.Network.routes_ahead`), and
each route is one line (`Network.route_track`). The routes are the hypotheses of the
multiple-model bank (`railnav.navigation.bank`, one constrained filter per route in
lockstep): before the first switch the routes share their geometry, so their filters
agree and their probabilities stay equal; after it, the GNSS evidence separates them.
The train can not change route after a switch, so the bank's crossing rate is 0 by
default (a static bank), and a route the train did not take dies when its filter's
vehicle leaves it (a buffer stop, or the horizon).

* `route_candidates`: the routes and their lines;
* `run_simulated_network`: simulate a trip along one route and identify it;
* `run_files_network`: identify the route of recorded (or simulated) sensor files.

Both return `railnav.jobs.tracks.TrackRunOutcome`, written by `write_track_run`; the
track names are the routes' netelements joined by ``>`` (``-`` marks an element
travelled against its direction).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from railnav.defaults import DEFAULT_HORIZON_M
from railnav.errors import ConfigError
from railnav.jobs.tracks import TrackRunOutcome, run_files_tracks, run_simulated_tracks
from railnav.navigation.bank import TrackBankConfig
from railnav.simulation.scenarios import Scenario
from trackmodel.errors import TrackError
from trackmodel.network import NetPosition, Network, Route

__all__ = ["route_candidates", "route_name", "run_simulated_network", "run_files_network",
           "NETWORK_BANK", "DEFAULT_HORIZON_M", "DEFAULT_MAX_ROUTES"]

#: A static bank: a train does not change route between switches.
NETWORK_BANK = TrackBankConfig(crossing_rate_per_s=0.0)
#: The most routes a run follows.
DEFAULT_MAX_ROUTES = 16


def route_name(route: Route) -> str:
    """``E1>E2>-E3``: the netelements of a route in order (``-``: travelled backwards)."""
    return ">".join(e if d == 1 else f"-{e}" for e, d in route.legs)


def route_candidates(network: Network, start: NetPosition, *,
                     horizon_m: float = DEFAULT_HORIZON_M,
                     max_routes: int = DEFAULT_MAX_ROUTES):
    """The routes a train at `start` may take within `horizon_m`, their lines, and where
    the train is on each line.

    Returns
    -------
    names : tuple of str
        `route_name` of each route.
    tracks : list of trackmodel.Track
        The route lines (each starts at the first leg's entry end).
    start_s : float
        Distance of `start` along every route line, m.

    Raises
    ------
    ConfigError
        No route ahead, or too many (`max_routes`).
    """
    try:
        routes = network.routes_ahead(start, horizon_m=horizon_m, max_routes=max_routes)
    except TrackError as exc:
        raise ConfigError(str(exc)) from None
    length = network.length_m(start.element)
    start_s = start.s_m if start.direction == 1 else length - start.s_m
    return (tuple(route_name(r) for r in routes),
            [network.route_track(r.legs) for r in routes], float(start_s))


def run_simulated_network(network: Network, start: NetPosition, scenario: Scenario, *,
                          true_route: int = 0, horizon_m: float = DEFAULT_HORIZON_M,
                          bank: TrackBankConfig = NETWORK_BANK, seed: int = 0,
                          progress: Callable[[int, int], None] | None = None,
                          **kwargs) -> TrackRunOutcome:
    """Simulate `scenario` from `start` along route `true_route` (an index into
    `route_candidates`' order; the bank is not told) and identify the route.

    Other keyword arguments go to `railnav.jobs.tracks.run_simulated_tracks` (``config``,
    ``systems``, ``window``, ``faults``).
    """
    names, tracks, start_s = route_candidates(network, start, horizon_m=horizon_m)
    if not 0 <= true_route < len(tracks):
        raise ConfigError(f"true route {true_route} is not one of the {len(tracks)} routes")
    scenario = replace(scenario, start_s=start_s)
    return run_simulated_tracks(tracks, names, scenario, true_track=true_route, bank=bank,
                                seed=seed, progress=progress, **kwargs)


def run_files_network(network: Network, start: NetPosition, *,
                      horizon_m: float = DEFAULT_HORIZON_M,
                      bank: TrackBankConfig = NETWORK_BANK, **kwargs) -> TrackRunOutcome:
    """Identify the route of sensor files from `start` (keyword arguments of
    `railnav.jobs.tracks.run_files_tracks`: ``imu_path``, ``obs_path``, ``nav_path``, ...;
    each filter starts from the first GNSS fix projected onto its route)."""
    names, tracks, _ = route_candidates(network, start, horizon_m=horizon_m)
    if len(tracks) < 2:
        raise ConfigError(f"one route ahead of {start.element} within {horizon_m:g} m: "
                          "nothing to identify (run it as one track)")
    return run_files_tracks(tracks, names, bank=bank, **kwargs)
