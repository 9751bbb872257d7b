"""Routes named by their netelements, and networks from any file railnav reads.

A route written as text (``railnav network route``, ``railnav simulate --route``, a study's
track) is its netelements in order, separated by ``,`` or ``>``: ``E1,E2,E3``. A name may
carry ``-`` (travelled against its direction, from its last coordinate) or ``+``; without
a sign the direction of each netelement is the one that leads on to the next (the first
of a one-element route: ``+``). `route_track` turns such a route into the `Track` a train
on it runs on (`trackmodel.network.Network.route_line`), the line that ``railnav
simulate``/``run``/``study`` take like any track file.

`load_network` reads a network from a network folder, a GeoJSON file (netelements +
netrelations), an OpenStreetMap file (`trackmodel.osm`) or a railnav track file (a
one-element network named by the file's stem), fitting what needs fitting.
"""
from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.fit_defaults import DEFAULT_TOL_M
from trackmodel.network import Network
from trackmodel.track import Track

__all__ = ["parse_route", "route_legs", "route_track", "route_text", "load_network",
           "network_source_kind", "ROUTE_SEPARATORS"]

#: Separators between the netelements of a route written as text.
ROUTE_SEPARATORS = ",>"


def parse_route(text: str) -> list[tuple[str, int | None]]:
    """``[(netelement, direction or None)]`` of a route written as text (module docstring).

    Raises
    ------
    TrackError
        An empty route or an empty name.
    """
    names = [part.strip() for part in re.split(f"[{re.escape(ROUTE_SEPARATORS)}]", text)]
    if not text.strip() or any(not n or n in "+-" for n in names):
        raise TrackError(f"route {text!r}: netelements separated by ',' or '>', each "
                         "optionally signed -/+ (e.g. E1,-E2,E3)")
    return [(n[1:], -1 if n[0] == "-" else 1) if n[0] in "+-" else (n, None) for n in names]


def route_legs(network: Network, route: str | Sequence[tuple[str, int | None]]
               ) -> tuple[tuple[str, int], ...]:
    """The ``(netelement, direction)`` legs of a route: each unsigned name gets the
    direction that leads on to the next.

    Raises
    ------
    TrackError
        A netelement not in the network, or no way through the route as given.
    """
    named = parse_route(route) if isinstance(route, str) else list(route)
    for name, _ in named:
        if name not in network.elements:
            raise TrackError(f"route: no netelement {name!r} in the network")
    found = _walk(network, named, ())
    if found is None:
        text = ">".join(n if d is None else f"{'-' if d < 0 else ''}{n}" for n, d in named)
        raise TrackError(f"route {text}: no passage through these netelements in this order "
                         "(check the order, the signs and the navigability)")
    return found


def _walk(network: Network, named, legs: tuple) -> tuple | None:
    """Depth-first: the legs continuing `legs` through the rest of `named`."""
    if len(legs) == len(named):
        return legs
    name, given = named[len(legs)]
    options = (given,) if given is not None else (1, -1)
    for direction in options:
        if legs and (name, direction) not in network.successors(*legs[-1]):
            continue
        found = _walk(network, named, legs + ((name, direction),))
        if found is not None:
            return found
    return None


def route_text(legs: Sequence[tuple[str, int]]) -> str:
    """``E1>-E2>E3``: legs as text that `parse_route` reads back."""
    return ">".join(e if d == 1 else f"-{e}" for e, d in legs)


def route_track(network: Network, route: str | Sequence[tuple[str, int | None]]) -> Track:
    """The line of a route through `network` (module docstring), ``s`` from the start of
    its first netelement (its first coordinate, or its last if travelled ``-``).

    Raises
    ------
    TrackError
        An unknown netelement, no passage, or a joint no transition can follow.
    """
    return network.route_track(route_legs(network, route))


#: What `load_network` reads, by file name ending (a folder is a network folder).
_KINDS = {".geojson": "geojson", ".json": "geojson", ".csv": "track"}


def network_source_kind(path: str | os.PathLike) -> str:
    """``folder``, ``geojson``, ``osm`` or ``track`` by the path (raises TrackFileError for
    anything else)."""
    from trackmodel.osm import OSM_SUFFIXES
    p = Path(path)
    name = p.name.lower()
    if p.is_dir():
        return "folder"
    if any(name.endswith(s) for s in OSM_SUFFIXES):
        return "osm"
    kind = _KINDS.get(p.suffix.lower())
    if kind is None:
        raise TrackFileError("not a network: expected a network folder, .geojson, an "
                             "OpenStreetMap file (.osm, .osm.pbf) or a track .csv", path=path)
    return kind


def load_network(path: str | os.PathLike, *, tol_m: float = DEFAULT_TOL_M,
                 progress: Callable[[int, int], None] | None = None) -> Network:
    """The network in `path` (module docstring), fitted within `tol_m` where it is read
    from polylines.

    Raises
    ------
    TrackFileError
        A file of none of these kinds, a bad one, or a netelement that cannot be fitted
        (located: the file, then the netelement).
    """
    from trackmodel.io import read_track
    from trackmodel.network_io import (
        build_network,
        network_from_track,
        read_network,
        read_network_geojson,
    )
    kind = network_source_kind(path)
    if kind == "folder":
        return read_network(path)
    if kind == "track":
        return network_from_track(read_track(path), Path(path).stem)
    if kind == "osm":
        from trackmodel.osm import read_osm
        source = read_osm(path)
    else:
        source = read_network_geojson(path)
    try:
        return build_network(source, tol_m=tol_m, progress=progress)
    except TrackFileError:
        raise
    except TrackError as exc:                    # a netelement that cannot be fitted
        raise TrackFileError(str(exc), path=path) from None
