"""trackmodel — the Earth ellipsoid and the geometry of a rail line.

Owns: the Earth model (`trackmodel.earth`: WGS-84 and sphere, radii, geodetic <-> ECEF
<-> ENU), and the track as a function of the along-track distance ``s`` (m): section
tables of straights (the 2017 paper's loxodrome with exponential height), circular arcs
and clothoid transitions; queries ``s -> (φ, λ, h, r_e, u_n, du/ds)``; projection of
points onto the track; fitting of surveyed polylines; the track file format; track
networks of netelements joined by switches (`trackmodel.network`: successors, routes,
distances, projection onto candidates, kinks; `trackmodel.network_io`: GeoJSON/RINF import
and the network folder format).

Conventions (ARCHITECTURE.md): ``s`` in metres from the track start; azimuth ``A``
clockwise from north, elevation ``ϑ`` positive uphill, both radians inside;
``u_n = [cosϑ sinA, cosϑ cosA, sinϑ]`` in East-North-Up; curvature ``dA/ds`` in 1/m,
positive turning clockwise (to the right); cross-track offsets positive to the right of
the direction of increasing ``s``.

This is the lowest package: it imports nothing else of the project.
"""
from trackmodel.earth import WGS84, Ellipsoid, sphere
from trackmodel.errors import InputError, TrackError, TrackFileError
from trackmodel.io import read_track, write_track
from trackmodel.origin import Origin
from trackmodel.sections import Section
from trackmodel.track import Track, TrackPoint

__all__ = ["Ellipsoid", "WGS84", "sphere", "InputError", "TrackError", "TrackFileError",
           "Section", "Origin", "Track", "TrackPoint", "read_track", "write_track"]
