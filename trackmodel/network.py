"""Track networks: netelements (each a `Track`) joined by connections that a train may pass.

A *netelement* is one track between two switches or ends (the RINF/RailTopoModel word),
with its own along-track distance ``s`` from 0 at its first point to its length at its
last. A *connection* joins an end of one netelement (``a``, ``a_end``) to an end of
another (``b``, ``b_end``); ends are `START` (``s = 0``) and `END` (``s = length``). Its
*navigability* says which way a train may pass: ``both``, ``AB`` (from a to b only),
``BA`` or ``none`` (the ends touch, e.g. the two branches of a switch, but no train passes
from one to the other).

Travel is a direction along a netelement: ``+1`` (increasing ``s``) or ``-1``. The
network is searched as a directed graph whose nodes are ``(element, direction)``: leaving
``a`` through ``a_end`` (direction ``+1`` if that end is `END`) a train enters ``b``
through ``b_end`` and travels ``+1`` on it if that end is `START`. Routes and distances
along them come from this graph (`networkx`: Dijkstra, and Yen's k shortest simple paths).

Each connection carries its measured *kink*: the angle between the tangent of the track
it leaves and of the track it enters, in the direction of travel, from the fitted
netelements (`Connection.kink_rad`), and the gap between the two end points. Where the
geometry is continuous the kink is of the order of the fit's tolerance over the
element's length; a larger kink is reported (`Network.kinks`), never smoothed away.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import islice

import networkx as nx
import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.errors import TrackError
from trackmodel.network_lines import (
    ROUTE_MIN_RADIUS_M,
    ROUTE_REFIT_TOL_M,
    RouteLine,
    chain_tracks,
    reversed_track,
    route_line,
)
from trackmodel.track import Track

__all__ = ["Network", "Connection", "NetPosition", "Route", "START", "END", "NAVIGABILITY",
           "CONTINUOUS_KINK_RAD", "reversed_track", "chain_tracks", "RouteLine",
           "ROUTE_MIN_RADIUS_M", "ROUTE_REFIT_TOL_M"]

Array = npt.NDArray[np.float64]

log = logging.getLogger(__name__)

#: Netelement ends: its first point (``s = 0``) and its last (``s = length``).
START, END = 0, 1
#: Navigability of a connection: which way a train may pass from ``a`` to ``b``.
NAVIGABILITY = ("both", "AB", "BA", "none")
#: A kink below this is taken as a continuous tangent, rad (0.5°: a 0.5-m fit tolerance
#: over the last ~60 m of an element; switches diverge by 1/9–1/20 rad, i.e. 3–6°).
CONTINUOUS_KINK_RAD = math.radians(0.5)


@dataclass(frozen=True)
class NetPosition:
    """A position on the network: a netelement, the distance along it (m) and the
    direction of travel (+1: increasing ``s``, -1: decreasing)."""

    element: str
    s_m: float
    direction: int = 1

    def __post_init__(self) -> None:
        if self.direction not in (1, -1):
            raise TrackError(f"direction must be +1 or -1, got {self.direction!r}")


@dataclass(frozen=True)
class Connection:
    """Two netelement ends joined, and how a train may pass (module docstring).

    Attributes
    ----------
    a, b : str
        Netelement ids.
    a_end, b_end : int
        `START` or `END`.
    navigability : str
        One of `NAVIGABILITY`.
    kink_rad : float
        Angle between the tangents of the two tracks across the joint, in the direction of
        travel, rad in [0, π] (filled in by `Network`).
    gap_m : float
        Distance between the two end points, m (filled in by `Network`).
    """

    a: str
    a_end: int
    b: str
    b_end: int
    navigability: str = "both"
    kink_rad: float = float("nan")
    gap_m: float = float("nan")

    def passes(self, from_a: bool) -> bool:
        """Whether a train may pass from ``a`` to ``b`` (`from_a`) or from ``b`` to ``a``."""
        return self.navigability == "both" or self.navigability == ("AB" if from_a else "BA")


@dataclass(frozen=True)
class Route:
    """A way through the network: the ``(element, direction)`` legs in order, and the
    distance from the start position to the end position along them, m."""

    legs: tuple[tuple[str, int], ...]
    length_m: float


class Network:
    """A directed graph of netelements (module docstring).

    Parameters
    ----------
    elements : mapping of str to Track
        The netelements by id.
    connections : sequence of Connection
        Their joints (kink and gap are measured here from the tracks).
    attributes : mapping of str to mapping of str to str, optional
        Each netelement's attributes from its source (e.g. OpenStreetMap's ``railway``,
        ``gauge``, ``service``, ``usage``); kept and written, not interpreted.
    heights : bool
        Whether the netelements' heights are known (attribute ``heights``). A network read
        without them (OpenStreetMap, a GeoJSON file of ``[lon, lat]`` pairs) has tracks at
        ``h = 0``, a placeholder: a run on it writes no height (`railnav.jobs.network`).

    Raises
    ------
    TrackError
        A connection naming an unknown element, an end other than `START`/`END`, an
        unknown navigability, or an empty network.
    """

    def __init__(self, elements: Mapping[str, Track], connections: Sequence[Connection],
                 attributes: Mapping[str, Mapping[str, str]] | None = None, *,
                 heights: bool = True) -> None:
        if not elements:
            raise TrackError("a network needs at least one netelement")
        self.elements: dict[str, Track] = dict(elements)
        self.heights = bool(heights)
        self.attributes: dict[str, dict[str, str]] = {
            name: dict(values) for name, values in (attributes or {}).items()
            if name in self.elements and values}
        for c in connections:
            _check_connection(c, self.elements)
        self.connections = tuple(_measured(c, self.elements) for c in connections)
        self.graph = _travel_graph(self.elements, self.connections)
        self._reversed: dict[str, Track] = {}

    def length_m(self, element: str) -> float:
        """Length of a netelement, m."""
        return float(self._track(element).length_m)

    def successors(self, element: str, direction: int = 1) -> list[tuple[str, int]]:
        """Where a train travelling `direction` on `element` may go next: the
        ``(element, direction)`` it enters at the end it reaches."""
        return sorted(self.graph.successors((self._check(element), direction)))

    def predecessors(self, element: str, direction: int = 1) -> list[tuple[str, int]]:
        """Where a train travelling `direction` on `element` may have come from."""
        return sorted(self.graph.predecessors((self._check(element), direction)))

    def distance_m(self, start: NetPosition, end: NetPosition) -> float:
        """Distance along the shortest route from `start` (in its direction of travel) to
        `end` (in either direction), m; inf when no route leads there."""
        routes = self.routes(start, end, max_routes=1)
        return routes[0].length_m if routes else math.inf

    def routes(self, start: NetPosition, end: NetPosition, *, max_routes: int = 5
               ) -> list[Route]:
        """The shortest routes from `start` (in its direction of travel) to `end`, shortest
        first (Yen's algorithm; at most `max_routes`)."""
        self._check(start.element), self._check(end.element)
        out = []
        if start.element == end.element:
            ahead = (end.s_m - start.s_m) * start.direction
            if ahead >= 0:
                out.append(Route(((start.element, start.direction),), float(ahead)))
        graph = self.graph.copy()
        source, target = ("from", start.element), ("to", end.element)
        # edges weigh the element they leave; a path also pays what is ahead of the start,
        # so it pays the start element twice: its length is the path's weight less that
        graph.add_edge(source, (start.element, start.direction),
                       weight=self._ahead(start.element, start.direction, start.s_m))
        for direction in (1, -1):
            entry = self._behind(end.element, direction, end.s_m)
            graph.add_edge((end.element, direction), target, weight=entry)
        paid_twice = self.length_m(start.element)
        try:
            for path in islice(nx.shortest_simple_paths(graph, source, target, weight="weight"),
                               max_routes):
                legs = tuple(path[1:-1])
                if len(legs) == 1:
                    continue                     # the same element, handled above
                out.append(Route(legs, _path_length(graph, path) - paid_twice))
        except nx.NetworkXNoPath:
            pass
        return sorted(out, key=lambda r: r.length_m)[:max_routes]

    def routes_ahead(self, start: NetPosition, *, horizon_m: float, max_routes: int = 32
                     ) -> list[Route]:
        """Every way a train at `start` may go for `horizon_m` metres: the routes through
        each switch ahead, each cut at the horizon or ending at a buffer stop (`length_m`:
        the distance from `start` to that end). The hypotheses of a train whose next
        switch ways are unknown.

        Raises
        ------
        TrackError
            More than `max_routes` routes within the horizon (shorten it).
        """
        self._check(start.element)
        first = (start.element, start.direction)
        done, todo = [], [((first,), self._ahead(start.element, start.direction, start.s_m))]
        while todo:
            legs, reach = todo.pop()
            nxt = [] if reach >= horizon_m else self.successors(*legs[-1])
            nxt = [n for n in nxt if n not in legs]          # no loop back onto itself
            if not nxt:
                done.append(Route(legs, float(reach)))
            todo.extend((legs + (n,), reach + self.length_m(n[0])) for n in nxt)
            if len(done) + len(todo) > max_routes:
                raise TrackError(f"more than {max_routes} routes within {horizon_m:g} m of "
                                 f"{start.element}: shorten the horizon")
        return sorted(done, key=lambda r: r.legs)

    def project(self, lat: npt.ArrayLike, lon: npt.ArrayLike, *, radius_m: float
                ) -> pd.DataFrame:
        """Candidate netelements within `radius_m` of each point (horizontal distance;
        `trackmodel.network_project.project_onto`).

        Parameters
        ----------
        lat, lon : array_like, shape (N,)
            Geodetic latitude and longitude, rad.
        radius_m : float

        Returns
        -------
        pandas.DataFrame
            ``point, element, s_m, cross_track_m, distance_m``, one row per candidate,
            sorted by point then distance.
        """
        from trackmodel.network_project import project_onto
        return project_onto(self.elements, lat, lon, radius_m=radius_m)

    def route_track(self, legs: Sequence[tuple[str, int]], *,
                    refit_tol_m: float | None = ROUTE_REFIT_TOL_M) -> Track:
        """One `Track` along a route's legs: the line a train on that route runs on, with
        ``s`` from the start of the first leg (`route_line`'s track).

        ``refit_tol_m=None``: the legs chained as they are (`chain_tracks`; a kink above
        the track model's limit is then an error).

        Raises
        ------
        TrackError
            A leg that does not lead to the next, or a joint no transition can follow.
        """
        if refit_tol_m is None:
            return chain_tracks(self._leg_tracks(legs))
        return self.route_line(legs, tol_m=refit_tol_m).track

    def route_line(self, legs: Sequence[tuple[str, int]], *,
                   tol_m: float = ROUTE_REFIT_TOL_M) -> RouteLine:
        """The line along a route's legs with its joint transitions, and where each leg
        lies on it (`trackmodel.network_lines`: two routes that share their first legs
        share the line's geometry on them exactly).

        Raises
        ------
        TrackError
            A leg that does not lead to the next, or a joint no transition within `tol_m`
            can follow.
        """
        tracks = self._leg_tracks(legs)
        try:
            return route_line(tuple(legs), tracks, tol_m=tol_m, min_radius_m=ROUTE_MIN_RADIUS_M)
        except TrackError as exc:
            raise TrackError(f"route {'>'.join(e for e, _ in legs)}: {exc}") from None

    def _leg_tracks(self, legs: Sequence[tuple[str, int]]) -> list[Track]:
        """Each leg's track oriented in its direction of travel, the passages checked."""
        if not legs:
            raise TrackError("a route needs at least one netelement")
        for (a, da), (b, db) in zip(legs[:-1], legs[1:]):
            if (b, db) not in self.graph.successors((self._check(a), da)):
                raise TrackError(f"route: no passage from {a} to {b}")
        return [self.oriented(e, d) for e, d in legs]

    def oriented(self, element: str, direction: int) -> Track:
        """`element`'s track in `direction` (+1 its own, -1 `reversed_track`; reversed
        tracks built once per network and kept: every run on the network shares them)."""
        if direction == 1:
            return self._track(element)
        if element not in self._reversed:
            self._reversed[element] = reversed_track(self._track(element))
        return self._reversed[element]

    def kinks(self) -> pd.DataFrame:
        """Every navigable connection with its kink (deg), gap (m) and whether the tangent
        is continuous there (`CONTINUOUS_KINK_RAD`)."""
        rows = [{"a": c.a, "a_end": c.a_end, "b": c.b, "b_end": c.b_end,
                 "navigability": c.navigability, "kink_deg": math.degrees(c.kink_rad),
                 "gap_m": c.gap_m, "continuous": c.kink_rad < CONTINUOUS_KINK_RAD}
                for c in self.connections if c.navigability != "none"]
        return pd.DataFrame(rows)

    def _track(self, element: str) -> Track:
        return self.elements[self._check(element)]

    def _check(self, element: str) -> str:
        if element not in self.elements:
            raise TrackError(f"no netelement {element!r} in the network")
        return element

    def _ahead(self, element: str, direction: int, s_m: float) -> float:
        """Distance from `s_m` to the end reached travelling `direction`, m."""
        length = self.length_m(element)
        return float(length - s_m if direction == 1 else s_m)

    def _behind(self, element: str, direction: int, s_m: float) -> float:
        """Distance from the end a train travelling `direction` enters by to `s_m`, m."""
        return float(s_m if direction == 1 else self.length_m(element) - s_m)


def _check_connection(c: Connection, elements: Mapping[str, Track]) -> None:
    for name in (c.a, c.b):
        if name not in elements:
            raise TrackError(f"connection {c.a}-{c.b}: no netelement {name!r}")
    if c.a_end not in (START, END) or c.b_end not in (START, END):
        raise TrackError(f"connection {c.a}-{c.b}: ends must be 0 (start) or 1 (end), got "
                         f"{c.a_end!r}, {c.b_end!r}")
    if c.navigability not in NAVIGABILITY:
        raise TrackError(f"connection {c.a}-{c.b}: navigability must be one of "
                         f"{', '.join(NAVIGABILITY)}, got {c.navigability!r}")


def _end_point(track: Track, end: int):
    return track.at(np.array([0.0 if end == START else track.length_m]))


def _leaving_azimuth(track: Track, end: int) -> float:
    """Azimuth of travel when leaving `track` through `end`, rad."""
    azimuth = float(_end_point(track, end).azimuth[0])
    return azimuth if end == END else azimuth + math.pi


def _measured(c: Connection, elements: Mapping[str, Track]) -> Connection:
    """`c` with its kink and gap from the tracks."""
    a, b = elements[c.a], elements[c.b]
    leave = _leaving_azimuth(a, c.a_end)
    enter = _leaving_azimuth(b, c.b_end) + math.pi      # entering b = reverse of leaving it
    kink = abs((leave - enter + math.pi) % (2 * math.pi) - math.pi)
    gap = float(np.linalg.norm(_end_point(a, c.a_end).r_e[0] - _end_point(b, c.b_end).r_e[0]))
    return Connection(c.a, c.a_end, c.b, c.b_end, c.navigability, kink, gap)


def _travel_graph(elements: Mapping[str, Track], connections: Iterable[Connection]
                  ) -> nx.DiGraph:
    """Nodes ``(element, direction)``; an edge for each way a train may pass a joint,
    weighted by the length of the element it leaves."""
    graph = nx.DiGraph()
    for name in elements:
        graph.add_nodes_from([(name, 1), (name, -1)])
    for c in connections:
        for (x, x_end, y, y_end), ok in (((c.a, c.a_end, c.b, c.b_end), c.passes(True)),
                                         ((c.b, c.b_end, c.a, c.a_end), c.passes(False))):
            if not ok:
                continue
            leaving = (x, 1 if x_end == END else -1)
            entering = (y, 1 if y_end == START else -1)
            graph.add_edge(leaving, entering, weight=float(elements[x].length_m))
    return graph


def _path_length(graph: nx.DiGraph, path: list) -> float:
    return float(sum(graph[u][v]["weight"] for u, v in zip(path[:-1], path[1:])))
