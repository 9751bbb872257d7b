"""Track network files: GeoJSON netelements + netrelations in, fitted networks in and out.

* `read_network_geojson` reads the layout of ERA RINF topology exports and of tp-lib's test
  data (the shipped Brussels network): a FeatureCollection of ``LineString`` netelements
  (``properties.id``; WGS-84 lon/lat, optional height) and ``Point`` netrelations
  (``properties``: ``netelementA``, ``netelementB``, ``positionOnA``/``positionOnB`` = 0 for
  an element's first coordinate, 1 for its last, ``navigability`` = ``both``, ``AB``, ``BA``
  or ``none``). It returns plain data (`NetworkSource`) with located one-line errors.
* `build_network` fits each netelement's polyline with `trackmodel.fit.fit_track` and
  joins them (`trackmodel.network.Network`).
* `write_network` / `read_network` (from `trackmodel.network_folder`): a fitted network as
  a folder, ``connections.csv`` plus one track file per netelement.

**Heights.** A network knows whether it has heights (`Network.heights`). A GeoJSON file
has them when every netelement's coordinates are ``[lon, lat, h]`` (``h`` ellipsoidal, m,
fitted into each track's vertical profile); when only some netelements have them the
network is read without heights (one warning: a run must not have a height on some
netelements and none on others), and a netelement mixing both forms is an error.
OpenStreetMap has none. A network without heights has tracks at ``h = 0``, a
placeholder; its folder says so (`trackmodel.network_folder`) and its GeoJSON export has
``[lon, lat]`` pairs.
"""
from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.files import atomic_write_text
from trackmodel.network import (
    NAVIGABILITY,
    ROUTE_MIN_RADIUS_M,
    START,
    Connection,
    Network,
)
from trackmodel.network_folder import heights_known, read_network, write_network
from trackmodel.track import Track

__all__ = ["NetworkSource", "read_network_geojson", "write_network_geojson", "build_network",
           "write_network", "read_network", "network_from_track", "NETWORK_MIN_RADIUS_M",
           "GEOJSON_STEP_M"]

Array = npt.NDArray[np.float64]

log = logging.getLogger(__name__)

#: Smallest radius of a fitted netelement, m (that of a route line's transitions).
NETWORK_MIN_RADIUS_M = ROUTE_MIN_RADIUS_M
#: Spacing of the points of an exported netelement, m: the chord of a 300-m radius
#: over 5 m is 1 cm from the arc, a 15-m radius's 21 cm (within the fit tolerance).
GEOJSON_STEP_M = 5.0
#: Decimal places of exported degrees (1e-8 degree is ~1 mm).
GEOJSON_DECIMALS = 8
#: Decimal places of exported heights, m.
GEOJSON_HEIGHT_DECIMALS = 3


@dataclass(frozen=True)
class NetworkSource:
    """A network as read from a file, before fitting.

    Attributes
    ----------
    polylines : dict of str to (lat, lon)
        Each netelement's points in its order, rad, shape (N,) each.
    connections : tuple of Connection
    attributes : dict of str to dict of str to str
        Each netelement's other properties (GeoJSON) or tags (OpenStreetMap), as text.
    heights : dict of str to ndarray, or None
        Each netelement's ellipsoidal heights at its points, m, shape (N,); None for a
        source without heights (module docstring).
    """

    polylines: dict[str, tuple[Array, Array]]
    connections: tuple[Connection, ...]
    attributes: dict[str, dict[str, str]] = field(default_factory=dict)
    heights: dict[str, Array] | None = None


def read_network_geojson(path: str | os.PathLike) -> NetworkSource:
    """Netelements and netrelations from a GeoJSON file (module docstring).

    Raises
    ------
    TrackFileError
        Not JSON, not a FeatureCollection, a feature without the fields of its kind, a
        coordinate out of range, a relation naming an unknown netelement, no netelement.
    """
    try:
        data = json.loads(Path(path).read_bytes().decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise TrackFileError(f"not a readable GeoJSON file ({exc})", path=path) from None
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        raise TrackFileError("expected a GeoJSON FeatureCollection", path=path)
    polylines, relations, attributes, heights = {}, [], {}, {}
    features = data.get("features")
    if not isinstance(features, list):
        raise TrackFileError("the FeatureCollection has no list of features", path=path)
    for k, feature in enumerate(features):
        geometry = feature.get("geometry") if isinstance(feature, dict) else None
        kind = geometry.get("type") if isinstance(geometry, dict) else None
        if kind == "LineString":
            name, lat_lon, h = _netelement(feature, k, path)
            if name in polylines:
                raise TrackFileError(f"feature {k}: netelement {name!r} given twice", path=path)
            polylines[name] = lat_lon
            if h is not None:
                heights[name] = h
            attributes[name] = _attributes(feature["properties"])
        elif kind == "Point" and "netelementA" in _properties(feature):
            relations.append((k, feature["properties"]))
    if not polylines:
        raise TrackFileError("no LineString netelement in the file", path=path)
    connections = [_relation(k, props, polylines, path) for k, props in relations]
    return NetworkSource(polylines, _merged(connections, path), attributes,
                         heights if heights_known(heights, len(polylines), path) else None)


def _properties(feature: dict) -> dict:
    props = feature.get("properties")
    return props if isinstance(props, dict) else {}


#: Netelement properties that are the format's own, not attributes.
_OWN_PROPERTIES = {"id", "type"}


def _attributes(props: dict) -> dict[str, str]:
    """A netelement's other scalar properties, as text."""
    return {str(k): str(v) for k, v in props.items()
            if k not in _OWN_PROPERTIES and isinstance(v, (str, int, float, bool))
            and str(v) != ""}


#: Navigability as the set of passages it allows, and back.
_ALLOWS = {"both": frozenset("ab"), "AB": frozenset("a"), "BA": frozenset("b"),
           "none": frozenset()}
_NAMED = {v: k for k, v in _ALLOWS.items()}


def _merged(connections: list[Connection], path) -> tuple[Connection, ...]:
    """One connection per pair of ends. A pair given twice keeps what both allow (the more
    restrictive navigability) with one warning naming it: the shipped Brussels file gives
    ``88_L_262``-``88_L_11886`` (the two branches of a switch, a 180° kink) as ``both``
    and as ``none``."""
    out: dict[tuple, Connection] = {}
    for c in connections:
        forward = (c.a, c.a_end) <= (c.b, c.b_end)
        key = ((c.a, c.a_end), (c.b, c.b_end)) if forward else ((c.b, c.b_end), (c.a, c.a_end))
        allows = _ALLOWS[c.navigability] if forward else frozenset(
            {"a": "b", "b": "a"}[x] for x in _ALLOWS[c.navigability])
        if key in out:
            before = _ALLOWS[out[key].navigability]
            if before != allows:
                log.warning("%s: netrelation %s-%s given twice (%s, %s): kept what both allow",
                            path, c.a, c.b, _NAMED[before], _NAMED[allows])
            allows = before & allows
        (a, a_end), (b, b_end) = key
        out[key] = Connection(a, a_end, b, b_end, _NAMED[allows])
    return tuple(out.values())


def _netelement(feature: dict, k: int, path) -> tuple[str, tuple[Array, Array], Array | None]:
    name = _properties(feature).get("id")
    if not isinstance(name, str) or not name:
        raise TrackFileError(f"feature {k}: a netelement needs a string properties.id",
                             path=path)
    try:
        xyz = np.array(feature["geometry"]["coordinates"], dtype=float)
        if xyz.ndim != 2 or xyz.shape[1] not in (2, 3):
            raise ValueError
    except (KeyError, TypeError, ValueError, IndexError, OverflowError):
        raise TrackFileError(f"feature {k} ({name}): coordinates are not all [lon, lat] or "
                             "all [lon, lat, h]", path=path) from None
    xy = xyz[:, :2]
    if xyz.shape[0] < 2 or not np.all(np.isfinite(xyz)):
        raise TrackFileError(f"feature {k} ({name}): need >= 2 finite points", path=path)
    if np.any(np.abs(xy[:, 0]) > 180) or np.any(np.abs(xy[:, 1]) > 90):
        raise TrackFileError(f"feature {k} ({name}): lon must be in [-180, 180] and lat in "
                             "[-90, 90] degrees", path=path)
    h = xyz[:, 2].copy() if xyz.shape[1] == 3 else None
    return name, (np.radians(xy[:, 1]), np.radians(xy[:, 0])), h


def _relation(k: int, props: dict, polylines: dict, path) -> Connection:
    try:
        a, b = props["netelementA"], props["netelementB"]
        ends = props["positionOnA"], props["positionOnB"]
    except KeyError:
        raise TrackFileError(f"feature {k}: a netrelation needs netelementA/B and "
                             "positionOnA/B", path=path) from None
    navigability = props.get("navigability", "both")
    for name in (a, b):
        if not isinstance(name, str) or name not in polylines:
            raise TrackFileError(f"feature {k}: netrelation names netelement {name!r}, which "
                                 "the file does not have", path=path)
    if any(isinstance(e, bool) or str(e) not in ("0", "1", "0.0", "1.0") for e in ends):
        raise TrackFileError(f"feature {k}: positionOnA/B must be 0 or 1, got "
                             f"{ends[0]!r}, {ends[1]!r}", path=path)
    if navigability not in NAVIGABILITY:
        raise TrackFileError(f"feature {k}: navigability must be one of "
                             f"{', '.join(NAVIGABILITY)}, got {navigability!r}", path=path)
    return Connection(a, int(float(ends[0])), b, int(float(ends[1])), navigability)


def build_network(source: NetworkSource, *, tol_m: float = 0.5,
                  min_radius_m: float = NETWORK_MIN_RADIUS_M,
                  progress: Callable[[int, int], None] | None = None) -> Network:
    """Fit every netelement (`trackmodel.fit.fit_track`, with its heights when the source
    has them) and join them.

    Parameters
    ----------
    source : NetworkSource
    tol_m : float
        Largest horizontal deviation of a netelement's points from its track, m.
    min_radius_m : float
        Smallest radius of a fitted curve, m.
    progress : callable(done, total), optional
        Called after each netelement.

    Raises
    ------
    TrackError
        A netelement that cannot be fitted (the message names it).
    """
    from trackmodel.fit import fit_track    # SciPy's optimize and interpolate: only to fit
    elements = {}
    total = len(source.polylines)
    heights = source.heights
    for i, (name, (lat, lon)) in enumerate(source.polylines.items()):
        h = None if heights is None else heights[name]
        try:
            elements[name] = fit_track(lat, lon, h, tol_m=tol_m,
                                       min_radius_m=min_radius_m).track
        except TrackError as exc:
            raise TrackError(f"netelement {name}: {exc}") from None
        if progress is not None:
            progress(i + 1, total)
    return Network(elements, source.connections, source.attributes,
                   heights=heights is not None)


def write_network_geojson(network: Network, path: str | os.PathLike, *,
                          step_m: float = GEOJSON_STEP_M) -> None:
    """Write `network` as GeoJSON netelements + netrelations (the layout
    `read_network_geojson` reads): each netelement its fitted track sampled every
    <= `step_m` (WGS-84 lon/lat, degrees) with its attributes as properties; each
    connection a Point at its ``a`` end; ``[lon, lat, h]`` for a network with heights
    (`Network.heights`), else ``[lon, lat]``. Written atomically."""
    features = []
    for name, track in network.elements.items():
        n = max(2, int(np.ceil(track.length_m / step_m)) + 1)
        lat, lon, h = track.geodetic(np.linspace(0.0, track.length_m, n))
        columns = [np.round(np.degrees(lon), GEOJSON_DECIMALS),
                   np.round(np.degrees(lat), GEOJSON_DECIMALS)]
        if network.heights:
            columns.append(np.round(h, GEOJSON_HEIGHT_DECIMALS))
        coords = np.column_stack(columns).tolist()
        features.append({"type": "Feature",
                         "properties": {**network.attributes.get(name, {}), "id": name},
                         "geometry": {"type": "LineString", "coordinates": coords}})
    for c in network.connections:
        track = network.elements[c.a]
        lat, lon, _ = track.geodetic(0.0 if c.a_end == START else track.length_m)
        point = np.round([float(np.degrees(lon).item()), float(np.degrees(lat).item())],
                         GEOJSON_DECIMALS)
        features.append({"type": "Feature", "properties": {
            "id": f"{c.a}[{c.a_end}]-{c.b}[{c.b_end}]", "type": "netrelation",
            "netelementA": c.a, "positionOnA": c.a_end, "netelementB": c.b,
            "positionOnB": c.b_end, "navigability": c.navigability},
            "geometry": {"type": "Point", "coordinates": point.tolist()}})
    atomic_write_text(path, json.dumps({"type": "FeatureCollection", "features": features})
                      + "\n")


def network_from_track(track: Track, name: str) -> Network:
    """A one-element network: `track` as netelement `name`, no connections."""
    return Network({name: track}, [])
