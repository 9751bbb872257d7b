"""A trip simulated along one of the routes ahead of a start on a network, navigated from
that start: the public API of ``railnav network run`` without sensor files.

`route_scenario` is the trip (the `curvy` scenario's sensors at a constant speed, for a
given duration or 90 % of the shortest route ahead, so that it ends on every route the
train might take); `run_simulated_route` picks the true route among `route_candidates`,
simulates the trip along it and runs the network navigator told the start netelement only
(`railnav.jobs.network.run_simulated_network`). A notebook calls them as the command does,
with the same defaults.
"""
from __future__ import annotations

from dataclasses import replace

from railnav.defaults import DEFAULT_HORIZON_M, DEFAULT_NETWORK_SPEED_MPS, DEFAULT_SEED
from railnav.errors import ConfigError
from railnav.jobs.network import NetworkRunOutcome, route_candidates, run_simulated_network
from railnav.navigation.network_config import NetworkNavConfig
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import Scenario, get_scenario
from trackmodel.network import NetPosition, Network

__all__ = ["route_scenario", "run_simulated_route", "ROUTE_SCENARIO", "ROUTE_SHARE"]

#: The scenario whose sensors a trip along a route has.
ROUTE_SCENARIO = "curvy"
#: A trip without a duration runs this share of the shortest route ahead.
ROUTE_SHARE = 0.9


def route_scenario(network: Network, start: NetPosition, *,
                   speed_mps: float = DEFAULT_NETWORK_SPEED_MPS,
                   duration_s: float | None = None,
                   horizon_m: float = DEFAULT_HORIZON_M) -> Scenario:
    """The `ROUTE_SCENARIO` scenario's sensors at a constant speed, without outages.

    Parameters
    ----------
    network : Network
    start : trackmodel.network.NetPosition
        Where the train starts (netelement, m along it, direction).
    speed_mps : float
        The constant speed, m/s.
    duration_s : float, optional
        The trip's duration, s; default `ROUTE_SHARE` of the shortest route ahead of
        `start` within `horizon_m` (a trip must end on every route it might take).
    horizon_m : float
        How far ahead of `start` the routes are followed, m (`route_candidates`).

    Its ``start_s`` is the scenario's own; `run_simulated_route` sets it along the route.
    """
    if duration_s is None:
        routes = route_candidates(network, start, horizon_m=horizon_m)[1]
        duration_s = ROUTE_SHARE * min(r.length_m for r in routes) / speed_mps
    return replace(get_scenario(ROUTE_SCENARIO), profile=constant_speed(speed_mps),
                   duration_s=duration_s, outages=())


def run_simulated_route(network: Network, start: NetPosition, *, true_route: int = 0,
                        speed_mps: float = DEFAULT_NETWORK_SPEED_MPS,
                        duration_s: float | None = None,
                        horizon_m: float = DEFAULT_HORIZON_M, seed: int = DEFAULT_SEED,
                        nav: NetworkNavConfig = NetworkNavConfig(),
                        progress=None) -> NetworkRunOutcome:
    """Simulate a trip from `start` along route `true_route` of `route_candidates` and
    navigate it on `network`, told the start netelement only (``railnav network run``).

    Parameters
    ----------
    network : Network
    start : trackmodel.network.NetPosition
    true_route : int
        The route the trip takes: its index in ``route_candidates(network, start,
        horizon_m=horizon_m)`` (0 = the first; the navigator is not told).
    speed_mps, duration_s, horizon_m
        The trip (`route_scenario`): m/s, s, m.
    seed : int
        Random seed of the simulation.
    nav : NetworkNavConfig
        The network navigator's settings.
    progress : callable(done, total), optional

    Raises
    ------
    ConfigError
        No route ahead, too many, or `true_route` not one of them.
    """
    routes, start_s = route_candidates(network, start, horizon_m=horizon_m)[1:]
    if not 0 <= true_route < len(routes):
        raise ConfigError(f"true_route {true_route}: only {len(routes)} route(s) ahead of "
                          "the start", arguments=("true_route",))
    scenario = route_scenario(network, start, speed_mps=speed_mps, duration_s=duration_s,
                              horizon_m=horizon_m)
    return run_simulated_network(network, routes[true_route].legs,
                                 replace(scenario, start_s=start_s), seed=seed, nav=nav,
                                 known_start=True, progress=progress)
