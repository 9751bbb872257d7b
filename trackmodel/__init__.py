"""trackmodel — the Earth ellipsoid and the geometry of a rail line.

Owns: the Earth model (`trackmodel.earth`: WGS-84 and sphere, radii, geodetic <-> ECEF
<-> ENU), and the track as a function of the along-track distance ``s`` (m): section
tables of straights (the 2017 paper's loxodrome with exponential height), circular arcs
and clothoid transitions; queries ``s -> (φ, λ, h, r_e, u_n, du/ds)``; projection of
points onto the track; fitting of surveyed polylines; the track file format; track
networks of netelements joined by switches (`trackmodel.network`: successors, routes,
distances, projection onto candidates, kinks; `trackmodel.network_lines`: route lines;
`trackmodel.network_io`: GeoJSON/RINF in and out and the network folder format;
`trackmodel.osm`: OpenStreetMap; `trackmodel.network_check`: defects;
`trackmodel.network_routes`: routes named by their netelements, `load_network`).

Conventions (ARCHITECTURE.md): ``s`` in metres from the track start; azimuth ``A``
clockwise from north, elevation ``ϑ`` positive uphill, both radians inside;
``u_n = [cosϑ sinA, cosϑ cosA, sinϑ]`` in East-North-Up; curvature ``dA/ds`` in 1/m,
positive turning clockwise (to the right); cross-track offsets positive to the right of
the direction of increasing ``s``.

This is the lowest package: it imports nothing else of the project.

The names are imported on first use (PEP 562), so ``import trackmodel`` (and
``trackmodel.errors``) stays cheap: it imports neither SciPy nor pandas.
"""
from __future__ import annotations

import importlib

#: Public name -> the module that owns it.
_EXPORTS = {
    "Ellipsoid": "earth", "WGS84": "earth", "sphere": "earth", "InputError": "errors",
    "TrackError": "errors", "TrackFileError": "errors", "Section": "sections",
    "Origin": "origin", "Track": "track", "TrackPoint": "track", "read_track": "io",
    "write_track": "io", "Network": "network", "NetPosition": "network",
    "Connection": "network", "read_network": "network_io", "write_network": "network_io",
    "read_network_geojson": "network_io", "write_network_geojson": "network_io",
    "build_network": "network_io", "read_osm": "osm", "check_network": "network_check",
    "load_network": "network_routes", "route_legs": "network_routes",
    "route_track": "network_routes",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'trackmodel' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"trackmodel.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
