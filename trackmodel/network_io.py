"""Track network files: GeoJSON netelements + netrelations in, fitted networks in and out.

* `read_network_geojson` reads the layout of ERA RINF topology exports and of tp-lib's test
  data (the shipped Brussels network): a FeatureCollection of ``LineString`` netelements
  (``properties.id``; WGS-84 lon/lat, optional height) and ``Point`` netrelations
  (``properties``: ``netelementA``, ``netelementB``, ``positionOnA``/``positionOnB`` = 0 for
  an element's first coordinate, 1 for its last, ``navigability`` = ``both``, ``AB``, ``BA``
  or ``none``). It returns plain data (`NetworkSource`) with located one-line errors.
* `build_network` fits each netelement's polyline with `trackmodel.fit.fit_track` and
  joins them (`trackmodel.network.Network`).
* `write_network` / `read_network`: a fitted network as a folder, ``connections.csv``
  (``a, a_end, b, b_end, navigability``) plus one track file per netelement in
  ``elements/`` (`trackmodel.io`), listed in ``elements.csv`` (``element, file``).

**Heights.** A network knows whether it has heights (`Network.heights`). A GeoJSON file
has them when every netelement's coordinates are ``[lon, lat, h]`` (``h`` ellipsoidal, m,
fitted into each track's vertical profile); when only some netelements have them the
network is read without heights (one warning: a run must not have a height on some
netelements and none on others), and a netelement mixing both forms is an error.
OpenStreetMap has none. A network without heights has tracks at ``h = 0``, a
placeholder; its folder says so in the column ``heights`` of ``elements.csv`` (``no``; a
folder without the column, or a track file, has heights), and its GeoJSON export has
``[lon, lat]`` pairs.
"""
from __future__ import annotations

import json
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.files import atomic_write_csv, atomic_write_text
from trackmodel.io import read_track, write_track
from trackmodel.network import (
    NAVIGABILITY,
    ROUTE_MIN_RADIUS_M,
    START,
    Connection,
    Network,
)
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
#: Column of ``elements.csv`` saying whether a netelement has heights (module docstring).
HEIGHTS_COLUMN = "heights"


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
                         _all_or_none(heights, len(polylines), path))


def _all_or_none(heights: dict, count: int, path) -> dict | None:
    """The netelements' heights if every one of the `count` has them, else None (with a
    warning when only some have them: module docstring)."""
    if heights and len(heights) < count:
        log.warning("%s: %d of %d netelements have heights, the others not: the network is "
                    "read without heights", path, len(heights), count)
    return heights if len(heights) == count else None


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


def _file_name(element: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", element) + ".csv"


def write_network(network: Network, folder: str | os.PathLike) -> None:
    """Write a fitted network as a folder (module docstring). The folder is written
    beside the target and moved into place at the end, so an error leaves nothing
    half-written; an existing network folder there is replaced.

    Raises
    ------
    TrackError
        `folder` exists and is neither empty nor a network folder, or two netelement ids
        map to one file name.
    """
    out = Path(folder)
    if out.exists() and not (out.is_dir() and (not any(out.iterdir())
                                               or (out / "elements.csv").is_file())):
        raise TrackError(f"{out}: exists and is not a network folder")
    files = {name: _file_name(name) for name in network.elements}
    if len(set(files.values())) != len(files):
        raise TrackError("two netelement ids map to one file name")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        _write_folder(network, tmp, files)
        if out.exists():
            old = out.with_name(f".{out.name}.old-{tmp.name}")
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old)
        else:
            tmp.rename(out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)


def _write_folder(network: Network, out: Path, files: dict[str, str]) -> None:
    (out / "elements").mkdir()
    for name, track in network.elements.items():
        write_track(track, out / "elements" / files[name], comments=[f"netelement {name}"])
    index = pd.DataFrame({"element": list(files),
                          "file": [f"elements/{f}" for f in files.values()]})
    if not network.heights:
        index[HEIGHTS_COLUMN] = "no"
    keys = sorted({k for values in network.attributes.values() for k in values} - {*index})
    for key in keys:
        index[key] = [network.attributes.get(name, {}).get(key, "") for name in files]
    atomic_write_csv(out / "elements.csv", index)
    atomic_write_csv(out / "connections.csv", pd.DataFrame(
        [{"a": c.a, "a_end": c.a_end, "b": c.b, "b_end": c.b_end,
          "navigability": c.navigability} for c in network.connections],
        columns=["a", "a_end", "b", "b_end", "navigability"]))


def read_network(folder: str | os.PathLike) -> Network:
    """A network written by `write_network`.

    Raises
    ------
    TrackFileError
        A missing or malformed file (located).
    """
    root = Path(folder)
    index = _csv(root / "elements.csv", ("element", "file"))
    elements, attributes, heights = {}, {}, {}
    for i, row in enumerate(index.to_dict("records"), start=1):
        name, file = row.pop("element"), row.pop("file")
        heights[name] = _heights_cell(row.pop(HEIGHTS_COLUMN, ""), root / "elements.csv", i)
        if not name or name in elements:
            raise TrackFileError(f"netelement {name!r} empty or given twice",
                                 path=root / "elements.csv", row=i)
        try:
            target = (root / file).resolve()
            inside = root.resolve() in target.parents and target.is_file()
        except (OSError, ValueError):                 # a NUL byte, a loop of links
            inside = False
        if not inside:
            raise TrackFileError(f"file {file!r} is not a file inside the network folder",
                                 path=root / "elements.csv", row=i)
        elements[name] = read_track(target)
        attributes[name] = {k: v for k, v in row.items() if v != ""}
    table = _csv(root / "connections.csv", ("a", "a_end", "b", "b_end", "navigability"))
    connections = []
    for i, row in enumerate(table.itertuples(), start=1):
        try:
            a_end, b_end = int(row.a_end), int(row.b_end)
        except (TypeError, ValueError):
            raise TrackFileError("a_end and b_end must be 0 or 1", path=root / "connections.csv",
                                 row=i) from None
        connections.append(Connection(str(row.a), a_end, str(row.b), b_end,
                                      str(row.navigability)))
    known = {name for name, given in heights.items() if given}
    try:
        return Network(elements, connections, attributes, heights=_all_or_none(
            known, len(elements), root / "elements.csv") is not None)
    except TrackError as exc:
        raise TrackFileError(str(exc), path=root / "connections.csv") from None


def _heights_cell(text: str, path: Path, row: int) -> bool:
    """Whether a netelement of a folder has heights: ``heights`` = ``yes`` or empty (the
    default), or ``no``."""
    if text not in ("", "yes", "no"):
        raise TrackFileError(f"{HEIGHTS_COLUMN} must be yes, no or empty, got {text!r}",
                             path=path, row=row, column=HEIGHTS_COLUMN)
    return text != "no"


def _csv(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise TrackFileError(f"cannot read ({exc})", path=path) from None
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise TrackFileError(f"missing column(s) {', '.join(missing)}", path=path)
    return frame


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
