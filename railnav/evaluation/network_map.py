"""The map of a network (``railnav network plot``): netelements, switches, navigability,
optionally a route and fixes.

Left, the whole network in east/north metres (or km beyond `KM_EXTENT_M`) from its centre,
equal scales: netelements coloured by their ``railway`` attribute where they have one
(else one colour), joints where three or more ends meet (switches, crossings) as black
dots, open ends as short bars, a route drawn over it (▶ start, ■ end) and fixes as small
dots. Netelement names are written when there are at most `MAX_LABELS`.

Right, a zoom on one joint (the route's first switch, else the joint with most ends): each
leg within `ZOOM_M`, and every pair of ends there as a connector through the joint, green
where a train passes, dotted red where it does not: the navigability a reader can check.
Axes follow `railnav.evaluation.plot_style` (words and units, no offsets).
"""
from __future__ import annotations

import os
from collections import defaultdict

import numpy as np
import numpy.typing as npt

from railnav.evaluation.plot_style import plain_axis, save_png
from trackmodel.earth import ecef_to_enu, geodetic_to_ecef

__all__ = ["network_map_figure", "plot_network_map", "draw_network", "fix_points"]

Array = npt.NDArray[np.float64]

#: Beyond this extent the axes are in km.
KM_EXTENT_M = 5_000.0
#: Names are written on at most this many netelements.
MAX_LABELS = 40
#: Half-width of the zoom on a joint, m, and how far its connectors reach into each leg.
ZOOM_M = 60.0
CONNECTOR_M = 15.0
#: Spacing of the plotted points of a netelement, m.
STEP_M = 5.0
KIND_COLORS = {"rail": "C0", "light_rail": "C4", "tram": "C1", "subway": "C2",
               "narrow_gauge": "C5"}


class _Plane:
    """East/north (m) at the network's centre."""

    def __init__(self, network) -> None:
        starts = np.array([t.at(np.array([0.0])).r_e[0] for t in network.elements.values()])
        self.centre = starts.mean(axis=0)
        track = next(iter(network.elements.values()))
        self.earth = track.earth
        from trackmodel.earth import ecef_to_geodetic
        lat, lon, _ = ecef_to_geodetic(self.centre[None, :], earth=self.earth)
        self.origin = dict(lat0=float(lat[0]), lon0=float(lon[0]), h0=0.0, earth=self.earth)

    def track(self, track, s: Array | None = None) -> Array:
        if s is None:
            s = np.linspace(0.0, track.length_m, max(2, int(track.length_m / STEP_M) + 2))
        return ecef_to_enu(track.at(s).r_e, **self.origin)[:, :2]

    def points(self, lat_rad: Array, lon_rad: Array) -> Array:
        r = geodetic_to_ecef(lat_rad, lon_rad, np.zeros_like(lat_rad), earth=self.earth)
        return ecef_to_enu(r, **self.origin)[:, :2]


def _joints(network) -> dict[tuple[str, int], set]:
    """Each end that takes part in a connection -> the set of ends meeting it there."""
    groups: dict = defaultdict(set)
    for c in network.connections:
        group = groups[(c.a, c.a_end)] | groups[(c.b, c.b_end)] | {(c.a, c.a_end),
                                                                     (c.b, c.b_end)}
        for end in group:
            groups[end] = group
    return groups


def draw_network(ax, network, plane: _Plane, scale: float, *, labels: bool = True) -> None:
    """Netelements, switches and open ends on `ax` (coordinates / `scale`)."""
    kinds = set()
    for name, track in network.elements.items():
        kind = network.attributes.get(name, {}).get("railway")
        kinds.add(kind)
        en = plane.track(track) / scale
        ax.plot(en[:, 0], en[:, 1], color=KIND_COLORS.get(kind, "0.45"), lw=1.0, zorder=2)
        if labels and len(network.elements) <= MAX_LABELS:
            mid = en[len(en) // 2]
            ax.annotate(name, mid, fontsize=6, color="0.3", zorder=5)
    groups = _joints(network)
    switches = {frozenset(g) for g in groups.values() if len(g) >= 3}
    for group in sorted(switches, key=sorted):   # a set's order follows the string hash
        name, end = min(group)
        p = _end_en(network, plane, name, end) / scale
        ax.plot(p[0], p[1], "o", color="k", ms=3, zorder=4)
    open_ends = [(n, e) for n in network.elements for e in (0, 1) if (n, e) not in groups]
    if open_ends:
        p = np.array([_end_en(network, plane, n, e) for n, e in open_ends]) / scale
        ax.plot(p[:, 0], p[:, 1], "|", color="k", ms=6, zorder=4)
    for kind in sorted(kinds - {None}):
        ax.plot([], [], color=KIND_COLORS.get(kind, "0.45"), label=f"railway={kind}")
    ax.plot([], [], "o", color="k", ms=3, label=f"switch or crossing ({len(switches)})")
    ax.plot([], [], "|", color="k", ms=6, label=f"open end ({len(open_ends)})")


def _end_en(network, plane: _Plane, name: str, end: int) -> Array:
    track = network.elements[name]
    return plane.track(track, np.array([0.0 if end == 0 else track.length_m]))[0]


def network_map_figure(network, *, route=None, fixes=None, title: str | None = None):
    """The figure of the module docstring.

    Parameters
    ----------
    network : trackmodel.network.Network
    route : sequence of (netelement, direction), optional
    fixes : path, gnss_obs FixLog or (lat, lon) arrays in rad, optional
        GNSS fixes: a fix file (CSV, NMEA, UBX, GPX: `gnss_obs.read_fixes`), fixes read,
        or their latitudes and longitudes (``railnav network plot --fixes``).
    title : str, optional
    """
    from matplotlib.figure import Figure
    plane = _Plane(network)
    ends = np.array([_end_en(network, plane, n, e) for n in network.elements for e in (0, 1)])
    extent = float(np.ptp(ends, axis=0).max())
    scale, unit = (1e3, "km") if extent > KM_EXTENT_M else (1.0, "m")
    fig = Figure(figsize=(13, 7), layout="constrained")
    ax, zoom = fig.subplots(1, 2, width_ratios=(1.6, 1.0))
    draw_network(ax, network, plane, scale)
    if fixes is not None:
        lat, lon = fix_points(fixes)
        en = plane.points(lat, lon) / scale
        ax.plot(en[:, 0], en[:, 1], ".", color="C2", ms=2, zorder=3, label=f"fixes ({len(en)})")
    if route is not None:
        _draw_route(ax, network, route, plane, scale)
    total = sum(t.length_m for t in network.elements.values()) / 1e3
    ax.set(xlabel=f"east of the centre ({unit})", ylabel=f"north of the centre ({unit})",
           title=title or f"network: {len(network.elements)} netelements, {total:.1f} km, "
                          f"{len(network.connections)} joints")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=7)
    _zoom(zoom, network, plane, route)
    for a in (ax, zoom):
        plain_axis(a)
        a.ticklabel_format(axis="x", style="plain", useOffset=False)
    return fig


def _draw_route(ax, network, route, plane: _Plane, scale: float) -> None:
    line = network.route_track(tuple(route))
    en = plane.track(line) / scale
    ax.plot(en[:, 0], en[:, 1], color="C3", lw=2.5, alpha=0.8, zorder=3,
            label=f"route ({len(route)} netelements, {line.length_m / 1e3:.2f} km)")
    ax.plot(*en[0], ">", color="C3", ms=9, mec="k", zorder=6, label="route start")
    ax.plot(*en[-1], "s", color="C3", ms=8, mec="k", zorder=6, label="route end")


def _zoom_joint(network, route) -> frozenset | None:
    groups = _joints(network)
    if route is not None:
        for name, direction in route:
            group = groups.get((name, 1 if direction == 1 else 0))
            if group is not None and len(group) >= 3:
                return frozenset(group)
    if not groups:
        return None
    return frozenset(max(groups.values(), key=lambda g: (len(g), sorted(g))))


def _zoom(ax, network, plane: _Plane, route) -> None:
    group = _zoom_joint(network, route)
    if group is None:
        ax.text(0.5, 0.5, "no joints", ha="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    ends = sorted(group)
    centre = _end_en(network, plane, *ends[0])
    legs = {end: _leg_en(network, plane, end, ZOOM_M) - centre for end in ends}
    first = legs[ends[0]][-1]
    frame = _Frame(np.arctan2(first[1], first[0]))
    across = max(float(np.max(np.abs(frame(en)[:, 1]))) for en in legs.values())
    for (n, e), en in legs.items():
        xy = frame(en)
        ax.plot(xy[:, 0], xy[:, 1], color="0.45", lw=4, alpha=0.5, zorder=2)
        ax.annotate(f"{n}[{e}]", xy[-1], fontsize=7)
    for c in network.connections:
        if (c.a, c.a_end) in group:
            _connector(ax, network, plane, centre, frame, c)
    ax.plot([], [], color="C2", label="a train passes")
    ax.plot([], [], ":", color="C3", label="no passage")
    ax.plot(0, 0, "o", color="k", ms=4)
    half = max(1.3 * across, 2.0)
    ax.set(xlim=(-1.1 * ZOOM_M, 1.3 * ZOOM_M), ylim=(-half, half),
           xlabel="along the joint's first leg (m)",
           ylabel="across it (m; scale stretched)",
           title=f"joint of {len(group)} ends, each leg {ZOOM_M:g} m: navigability")
    ax.legend(loc="lower right", fontsize=7)


class _Frame:
    """Plane coordinates rotated so that a direction is the x axis."""

    def __init__(self, angle: float) -> None:
        self.c, self.s = float(np.cos(angle)), float(np.sin(angle))

    def __call__(self, en: Array) -> Array:
        en = np.atleast_2d(en)
        return np.column_stack([self.c * en[:, 0] + self.s * en[:, 1],
                                -self.s * en[:, 0] + self.c * en[:, 1]])


def _leg_en(network, plane: _Plane, end: tuple[str, int], reach_m: float) -> Array:
    """East/north of a netelement from its `end` to `reach_m` into it (from the end)."""
    name, e = end
    track = network.elements[name]
    reach = min(reach_m, track.length_m)
    s = np.linspace(0.0, reach, 40)
    return plane.track(track, s if e == 0 else track.length_m - s)


def _connector(ax, network, plane: _Plane, centre: Array, frame: _Frame, c) -> None:
    """A curve from `CONNECTOR_M` into leg a, bent through the joint (a quadratic Bézier
    whose control point is the joint), to `CONNECTOR_M` into b: straight for a straight
    passage, cutting the corner for a sharp one."""
    a = _leg_en(network, plane, (c.a, c.a_end), CONNECTOR_M)[-1] - centre
    b = _leg_en(network, plane, (c.b, c.b_end), CONNECTOR_M)[-1] - centre
    t = np.linspace(0.0, 1.0, 30)[:, None]
    path = frame((1 - t) ** 2 * a + t ** 2 * b)
    style = dict(color="C2", lw=1.5) if c.navigability != "none" else dict(
        color="C3", lw=1.0, ls=":")
    ax.plot(path[:, 0], path[:, 1], zorder=3, **style)


def fix_points(fixes) -> tuple[Array, Array]:
    """Latitudes and longitudes (rad) of `fixes`: a fix file's path, a
    `gnss_obs.fixes.FixLog` (its ``lat_deg``, ``lon_deg``), or (lat, lon) arrays in rad."""
    if isinstance(fixes, (str, os.PathLike)):
        from gnss_obs.fixes.read import read_fixes
        fixes = read_fixes(fixes)
    table = getattr(fixes, "table", None)
    if table is not None:
        return (np.radians(table["lat_deg"].to_numpy(float)),
                np.radians(table["lon_deg"].to_numpy(float)))
    return np.asarray(fixes[0], float), np.asarray(fixes[1], float)


def plot_network_map(network, path: str | os.PathLike, **kwargs) -> None:
    """`network_map_figure` written to a PNG file, atomically."""
    save_png(network_map_figure(network, **kwargs), path)
