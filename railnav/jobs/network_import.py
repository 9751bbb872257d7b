"""A network imported into a network folder (or GeoJSON): the public API of ``railnav
network import`` (and ``build``).

`import_network` reads any source `trackmodel.network_routes.load_network` reads (a
network folder, GeoJSON netelements + netrelations, OpenStreetMap, a track CSV), fitting
polylines within ``tol_m``; checks it (`trackmodel.network_check.check_network`): an error
stops it with nothing written, warnings are returned (and logged); and writes a network
folder (`trackmodel.network_io.write_network`) or, for a name ending in ``.geojson`` or
``.json``, GeoJSON (`write_network_geojson`).
"""
from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Callable

from railnav.errors import ConfigError
from trackmodel.fit_defaults import DEFAULT_TOL_M

__all__ = ["import_network", "GEOJSON_SUFFIXES"]

log = logging.getLogger(__name__)

#: An output with one of these suffixes is written as GeoJSON, else as a network folder.
GEOJSON_SUFFIXES = (".geojson", ".json")


def import_network(source: str | os.PathLike, out: str | os.PathLike, *,
                   tol_m: float = DEFAULT_TOL_M,
                   progress: Callable[[int, int], None] | None = None):
    """Read, check and write the network of `source` (module docstring).

    Parameters
    ----------
    source : path
        A network folder, GeoJSON, OpenStreetMap (.osm, .osm.pbf) or track .csv.
    out : path
        The network folder to write (replaced if it is one), or a GeoJSON file.
    tol_m : float
        Largest deviation of a netelement's points from its fitted track, m (a source read
        from polylines).
    progress : callable(done, total), optional
        Netelements fitted.

    Returns
    -------
    (trackmodel.network.Network, list of trackmodel.network_check.Finding)
        The network and the warnings of its check.

    Raises
    ------
    ConfigError
        The check found an error (the first named, and how many more); nothing written.
    """
    from trackmodel.network_check import check_network
    from trackmodel.network_io import write_network, write_network_geojson
    from trackmodel.network_routes import load_network
    network = load_network(source, tol_m=tol_m, progress=progress)
    findings = check_network(network, tol_m=tol_m)
    errors = [f for f in findings if f.level == "error"]
    if errors:
        more = f" (and {len(errors) - 1} more errors)" if len(errors) > 1 else ""
        raise ConfigError(f"{source}: {errors[0]}{more}; nothing written")
    for finding in findings:
        log.warning("%s: %s", source, finding)
    if Path(out).suffix.lower() in GEOJSON_SUFFIXES:
        write_network_geojson(network, out)
    else:
        write_network(network, out)
    return network, findings
