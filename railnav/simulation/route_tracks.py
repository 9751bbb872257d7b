"""Tracks named as network routes, ``NETWORK:E1,E2,...``: the track axis of a study.

A study's ``track`` entries are track files; an entry that is no file and has the form
``NETWORK:ROUTE`` names a route through a network instead: ``NETWORK`` a network folder,
GeoJSON or OpenStreetMap file relative to the configuration's folder or shipped in
``data/networks/`` (e.g. ``brussels_airport``), ``ROUTE`` its netelements as
`trackmodel.network_routes.parse_route` reads them (``88_L_111,88_L_154``). The route's
line (`trackmodel.network_routes.route_track`) is the track, carried as the text of its
track file like any other (so its digest names the run).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from railnav_data import NETWORKS, shipped_path

from railnav.errors import ConfigError
from trackmodel.errors import TrackError

__all__ = ["split_route_spec", "route_spec_text", "NETWORKS_DIR"]

NETWORKS_DIR = shipped_path(NETWORKS)


def split_route_spec(text: str) -> tuple[str, str] | None:
    """``(network, route)`` of ``NETWORK:ROUTE``, or None for anything else."""
    network, sep, route = text.rpartition(":")
    return (network, route) if sep and network and route else None


def _network_path(network: str, base_dir: Path) -> Path:
    for candidate in (base_dir / network, NETWORKS_DIR / network):
        if candidate.exists():
            return candidate
    raise ConfigError(f"network {network!r} not found (looked in {base_dir} and {NETWORKS_DIR})")


def route_spec_text(spec: str, base_dir: Path) -> str:
    """The track-file text of the route `spec` names (module docstring).

    Raises
    ------
    ConfigError
        Not a ``NETWORK:ROUTE``, no such network, or a route it does not have.
    """
    parts = split_route_spec(spec)
    if parts is None:
        raise ConfigError(f"track {spec!r}: neither a track file nor NETWORK:E1,E2,...")
    path = _network_path(parts[0], Path(base_dir))
    try:
        return _route_text(str(path.resolve()), parts[1])
    except TrackError as exc:
        raise ConfigError(f"track {spec!r}: {exc}") from None


@lru_cache(maxsize=32)
def _route_text(network: str, route: str) -> str:
    from trackmodel.io import track_to_text
    from trackmodel.network_routes import load_network, route_legs, route_text
    net = load_network(network)
    legs = route_legs(net, route)
    return track_to_text(net.route_track(legs), comments=[f"route {route_text(legs)} of "
                                                          f"{Path(network).name}"])
