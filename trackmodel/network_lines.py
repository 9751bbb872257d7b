"""Lines along a network: a track reversed, tracks chained, and a route's line.

A route is a sequence of netelements, each travelled one way (`trackmodel.network`). Its
*line* is one `Track` along the legs, with ``s`` from the start of the first leg. The legs
meet at joints that are rarely tangent-continuous: a switch's diverging branch leaves at
its angle (5-11° measured on the Brussels network), and the two end points of a joint may
be apart (up to 0.84 m there). Chained as they are, the line would take an instant turn,
which no vehicle makes and which an inertial filter cannot follow.

**The joint transition** (`route_line`). At each joint the line keeps the leg it leaves
unchanged, to its end, and absorbs the kink and the gap on the leg it enters: from the end
of the leg left, with its azimuth, a *biarc* (two circular arcs, equal tangent lengths: the
classical G1 Hermite interpolant, closed form) runs to the point at distance ``L`` along
the entered leg, arriving with that leg's azimuth there; from there the line follows the
entered leg's own sections. ``L`` is the longest of `TRANSITION_MAX_M`, the entered leg's
length, and that times 0.8, 0.8², ..., for which the biarc stays within the tolerance of
the entered leg's line (or within the joint's gap, if that is larger), with radii of at
least `ROUTE_MIN_RADIUS_M`.

Consequences, each tested:

* **A common prefix is shared exactly.** A leg's piece of the line depends only on that leg
  and the one before it. Two routes that share their first ``k`` legs have identical
  sections on them, so identical geometry (the same floats), up to the end of leg ``k``:
  the switch where they part. (A refit of the whole route, as before, differed by up to
  0.15 m before the switch, and a simulated truth on one route leaked evidence through it
  before the routes parted.)
* The line is within the tolerance of every leg's own line, except within a joint's gap.
* At a trailing joint (two branches merging) the transition lies on the merged leg, after
  the joint, where the real turnout's curve lies before it: within the tolerance either way.

`RouteLine.element_at` maps the line's ``s`` back to ``(netelement, offset from its first
coordinate)``: within a transition of line length ``l`` covering ``L`` of the leg, linearly;
beyond it, one to one.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.earth import ecef_to_enu, ecef_to_geodetic, enu_to_ecef
from trackmodel.errors import TrackError
from trackmodel.sections import Section
from trackmodel.track import Track

__all__ = ["RouteLine", "route_line", "reversed_track", "chain_tracks", "tail_sections",
           "ROUTE_REFIT_TOL_M", "ROUTE_MIN_RADIUS_M", "TRANSITION_MAX_M", "EXACT_KINK_RAD"]

Array = npt.NDArray[np.float64]

#: Largest deviation of a joint transition from the entered leg's line, m: the
#: netelements' own fit tolerance.
ROUTE_REFIT_TOL_M = 0.5
#: Smallest radius of a joint transition, m: below any railway's (tram loops ~15-20 m).
ROUTE_MIN_RADIUS_M = 15.0
#: Longest joint transition, m (a 1:9 turnout's curve is ~30 m long).
TRANSITION_MAX_M = 100.0
#: Each try of a shorter transition is this share of the previous one.
TRANSITION_SHRINK = 0.8
#: Shortest transition tried, m.
TRANSITION_MIN_M = 1.0
#: A joint within these of tangent-continuous and closed is chained as it is (rad, m).
EXACT_KINK_RAD, EXACT_GAP_M = 1e-9, 1e-6
#: Spacing of the points on which a transition's deviation is measured, m.
CHECK_STEP_M = 0.5
#: A transition that misses its target point by more than this is solved again aimed
#: off by the miss (the plane's small distortion over ~100 m), m.
AIM_TOL_M = 1e-4


@dataclass(frozen=True)
class RouteLine:
    """A route's line and where each leg lies on it.

    Attributes
    ----------
    track : Track
        The line, ``s`` from the start of the first leg, m.
    legs : tuple of (str, int)
        ``(netelement, direction)`` in order.
    starts_m : tuple of float
        ``s`` on the line where each leg begins (its entry joint), m.
    transitions : tuple of (float, float)
        Each leg's transition: its length on the line and the length of the leg it covers,
        m (``(0, 0)``: none).
    element_lengths_m : tuple of float
    """

    track: Track
    legs: tuple[tuple[str, int], ...]
    starts_m: tuple[float, ...]
    transitions: tuple[tuple[float, float], ...]
    element_lengths_m: tuple[float, ...]

    def element_at(self, s_m: float) -> tuple[str, float, int]:
        """``(netelement, offset from its first coordinate (m), direction)`` at ``s_m``
        on the line (module docstring)."""
        s_m = float(np.clip(s_m, 0.0, self.track.length_m))
        k = max(int(np.searchsorted(self.starts_m, s_m, side="right")) - 1, 0)
        (element, direction), u = self.legs[k], s_m - self.starts_m[k]
        line_l, leg_l = self.transitions[k]
        along = u * leg_l / line_l if u < line_l else leg_l + (u - line_l)
        along = min(along, self.element_lengths_m[k])
        return element, along if direction == 1 else self.element_lengths_m[k] - along, direction


def route_line(legs: Sequence[tuple[str, int]], tracks: Sequence[Track], *,
               tol_m: float = ROUTE_REFIT_TOL_M,
               min_radius_m: float = ROUTE_MIN_RADIUS_M) -> RouteLine:
    """The line along `tracks` (each already oriented in the direction of travel), named
    by `legs`, with a joint transition at every joint (module docstring).

    Raises
    ------
    TrackError
        A joint whose kink no transition within `tol_m` and with radii >= `min_radius_m`
        can follow (the message names the joint).
    """
    if not tracks or len(tracks) != len(legs):
        raise TrackError("a route line needs one track per leg")
    sections = list(tracks[0].sections)
    starts, transitions, s_m = [0.0], [(0.0, 0.0)], float(tracks[0].length_m)
    k = 1
    while k < len(tracks):
        try:
            piece, covered = _joint(tracks[k - 1], tracks[k:], tol_m, min_radius_m)
        except TrackError as exc:
            raise TrackError(f"joint {legs[k - 1][0]} -> {legs[k][0]}: {exc}") from None
        line_l = sum(sec.length_m for sec in piece)
        transition_l = line_l - sum(float(tracks[j].length_m) for j in range(k, k + len(covered))
                                    ) + sum(covered)
        for leg_l in covered:                   # the legs the transition covers, in turn
            share = transition_l * leg_l / sum(covered) if covered[-1] else 0.0
            starts.append(s_m)
            transitions.append((share, leg_l))
            s_m += share
            k += 1
        s_m += line_l - transition_l
        sections.extend(piece)
    line = Track(tuple(sections), tracks[0].origin, tracks[0].earth)
    return RouteLine(line, tuple(legs), tuple(starts), tuple(transitions),
                     tuple(float(t.length_m) for t in tracks))


def _joint(before: Track, after: Sequence[Track], tol_m: float, min_radius_m: float
           ) -> tuple[list[Section], list[float]]:
    """The line's sections from the end of `before` to the end of the leg the transition
    lands on, and the length of each entered leg it covers (all of a bridged leg, ``L`` of
    the last), m. A leg too short to hold the transition is bridged (module docstring)."""
    end = before.at(np.array([before.length_m]))
    start = after[0].at(np.array([0.0]))
    gap = float(np.linalg.norm(end.r_e[0] - start.r_e[0]))
    kink = abs(_wrap(float(start.azimuth[0] - end.azimuth[0])))
    if kink < EXACT_KINK_RAD and gap < EXACT_GAP_M:
        return tail_sections(after[0], 0.0), [0.0]
    bound = max(tol_m, gap + CHECK_STEP_M * kink + 1e-3)
    bridged = 0.0
    for j, target in enumerate(after):
        length = _landing(end, after[:j + 1], bound, min_radius_m)
        if length is not None:
            arcs = _transition(end, target, length)
            return (_arc_sections(arcs, end, target, length) + tail_sections(target, length),
                    [float(t.length_m) for t in after[:j]] + [length])
        bridged += float(target.length_m)
        if bridged >= TRANSITION_MAX_M:
            break
    raise TrackError(f"a kink of {math.degrees(kink):.1f}° and a gap of {gap:.2f} m: no "
                     f"transition within {bound:g} m with radii >= {min_radius_m:g} m")


def _landing(end, lines: Sequence[Track], bound: float, min_radius_m: float) -> float | None:
    """The longest ``L`` on the last of `lines` (module docstring) for a transition from
    `end` within `bound` of the lines, or None."""
    target = lines[-1]
    length = min(TRANSITION_MAX_M, float(target.length_m))
    while length >= min(TRANSITION_MIN_M, float(target.length_m)):
        at = target.at(np.array([length]))
        arcs = _biarc(float(end.azimuth[0]), _enu(at, end), float(at.azimuth[0]))
        if arcs is not None:
            radius = min(abs(1.0 / c) if c else math.inf for _, c in arcs)
            if radius < min_radius_m:
                return None                     # shorter ones only turn tighter
            if _deviation(arcs, end, lines) <= bound:
                return length
        length *= TRANSITION_SHRINK
    return None


def _enu(point, origin) -> Array:
    """Horizontal ENU (east, north) of `point` (a 1-point TrackPoint) at `origin`'s."""
    r_n = ecef_to_enu(point.r_e, lat0=float(origin.lat[0]), lon0=float(origin.lon[0]),
                      h0=float(origin.h[0]))
    return np.asarray(r_n, float).reshape(-1, 3)[0, :2]


def _transition(end, after: Track, length: float) -> list[tuple[float, float]]:
    """The biarc ``[(length, curvature)] * 2`` from `end` (position and azimuth) to
    `after` at `length`, aimed again off by its miss on the Earth (`AIM_TOL_M`)."""
    target = after.at(np.array([length]))
    p1, a1 = _enu(target, end), float(target.azimuth[0])
    aim, arcs = p1, None
    for _ in range(3):
        found = _biarc(float(end.azimuth[0]), aim, a1)
        if found is None:
            break
        arcs = found
        built = _arcs_track(arcs, float(end.azimuth[0]), end)
        miss = p1 - _enu(built.at(np.array([built.length_m])), end)
        if np.hypot(*miss) < AIM_TOL_M:
            break
        aim = aim + miss
    if arcs is None:
        raise TrackError("the transition's target lies behind its start")
    return arcs


def _arcs_track(arcs, a0: float, end) -> Track:
    secs = [Section(arcs[0][0], math.degrees(a0) % 360.0, 0.0, arcs[0][1]),
            Section(arcs[1][0], None, None, arcs[1][1])]
    return Track.from_sections(secs, lat=float(end.lat[0]), lon=float(end.lon[0]),
                               h=float(end.h[0]))


def _biarc(a0: float, p1: Array, a1: float) -> list[tuple[float, float]] | None:
    """Equal-tangent biarc from the origin with azimuth `a0` to `p1` (east, north, m) with
    azimuth `a1`: ``[(length, curvature)] * 2`` (curvature > 0 turning clockwise), or None
    when the target lies behind the start."""
    t0 = np.array([math.sin(a0), math.cos(a0)])
    t1 = np.array([math.sin(a1), math.cos(a1)])
    v, t = p1, t0 + t1
    vt, vv, c = float(v @ t), float(v @ v), float(t0 @ t1)
    if 1.0 - c < 1e-12:
        if vt <= 0.0:
            return None
        d = vv / (2.0 * vt)
    else:
        a = 2.0 * (c - 1.0)
        d = (2.0 * vt - math.sqrt(4.0 * vt * vt - 4.0 * a * vv)) / (2.0 * a)
    if not d > 0.0:
        return None
    mid = 0.5 * (d * t0 + p1 - d * t1)
    first = _arc(np.zeros(2), a0, mid)
    second = _arc(mid, a0 + first[0] * first[1], p1)
    return [first, second]


def _arc(p: Array, azimuth: float, q: Array) -> tuple[float, float]:
    """The circular arc from `p` leaving with `azimuth` through `q`: (length, curvature)."""
    chord = q - p
    c = float(np.hypot(*chord))
    phi = _wrap(math.atan2(chord[0], chord[1]) - azimuth)
    if abs(phi) < 1e-12:
        return c, 0.0
    return c * phi / math.sin(phi), 2.0 * math.sin(phi) / c


def _plane_points(arcs, a0: float, step_m: float) -> Array:
    """Points every <= `step_m` along the biarc in the plane (east, north), m."""
    out, p, azimuth = [np.zeros((1, 2))], np.zeros(2), a0
    for length, curvature in arcs:
        t = np.linspace(0.0, length, max(2, int(math.ceil(length / step_m)) + 1))[1:]
        if curvature == 0.0:
            d = np.column_stack([t * math.sin(azimuth), t * math.cos(azimuth)])
        else:
            r = 1.0 / curvature
            d = np.column_stack([r * (np.cos(azimuth) - np.cos(azimuth + curvature * t)),
                                 r * (np.sin(azimuth + curvature * t) - np.sin(azimuth))])
        out.append(p + d)
        p, azimuth = p + d[-1], azimuth + curvature * length
    return np.vstack(out)


def _deviation(arcs, end, lines: Sequence[Track]) -> float:
    """Largest horizontal distance of the transition from the nearest of `lines`, m."""
    xy = _plane_points(arcs, float(end.azimuth[0]), CHECK_STEP_M)
    r_n = np.column_stack([xy, np.zeros(len(xy))])
    lat0, lon0, h0 = float(end.lat[0]), float(end.lon[0]), float(end.h[0])
    lat, lon, _ = ecef_to_geodetic(enu_to_ecef(r_n, lat0=lat0, lon0=lon0, h0=h0))
    distance = np.full(len(xy), np.inf)
    for line in lines:
        proj = line.project(lat, lon)
        distance = np.minimum(distance, np.hypot(proj.cross_track_m, proj.along_m))
    return float(np.max(distance))


def _arc_sections(arcs, end, after: Track, length: float) -> list[Section]:
    """The transition's sections: azimuth from the leg left, elevation changing linearly
    from the leg left's to the entered leg's at `length`."""
    e0 = math.degrees(float(end.elevation[0]))
    e1 = math.degrees(float(after.at(np.array([length])).elevation[0]))
    share = arcs[0][0] / (arcs[0][0] + arcs[1][0])
    e_mid = e0 + share * (e1 - e0)
    return [Section(arcs[0][0], math.degrees(float(end.azimuth[0])) % 360.0, e0, arcs[0][1],
                    None, None if e_mid == e0 else e_mid),
            Section(arcs[1][0], None, None, arcs[1][1], None, None if e1 == e_mid else e1)]


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def tail_sections(track: Track, s0_m: float) -> list[Section]:
    """The sections of `track` from `s0_m` to its end, the first one cut at `s0_m` and
    starting with the track's azimuth and elevation there."""
    table = track.table
    k = int(track.section_of(np.array([s0_m]))[0]) if s0_m > 0.0 else 0
    t0 = s0_m - float(table.s_start[k])
    length = float(table.length[k])
    if length - t0 <= 1e-9 and k + 1 < len(track.sections):
        k, t0, length = k + 1, 0.0, float(table.length[k + 1])
    at = track.at(np.array([s0_m]))
    k0, k1 = float(table.curvature0[k]), float(table.curvature1[k])
    e0, e1 = float(table.elevation0[k]), float(table.elevation1[k])
    share = t0 / length
    k_cut = k0 + (k1 - k0) * share
    e_cut = e0 + (e1 - e0) * share
    first = Section(max(length - t0, 1e-9), math.degrees(float(at.azimuth[0])) % 360.0,
                    math.degrees(e_cut), k_cut, None if k0 == k1 else k1,
                    None if e0 == e1 else math.degrees(e1))
    return [first, *track.sections[k + 1:]]


def reversed_track(track: Track) -> Track:
    """The same line travelled the other way: ``s' = L - s``, sections in reverse order
    with curvature and elevation negated (and swapped end for start), from the old end.

    Exact in the track model: the azimuth of the reversed line is ``A + π`` and its
    ``dA/ds'`` is ``-dA/ds``; the loxodrome's exponential height law runs back into itself.
    """
    table, length = track.table, float(track.length_m)
    end = track.at(np.array([length]))
    sections = []
    for k in range(len(track.sections) - 1, -1, -1):
        k0, k1 = float(table.curvature0[k]), float(table.curvature1[k])
        e0, e1 = float(table.elevation0[k]), float(table.elevation1[k])
        sections.append(Section(float(table.length[k]), None, math.degrees(-e1), -k1,
                                None if k0 == k1 else -k0,
                                None if e0 == e1 else math.degrees(-e0)))
    first = sections[0]
    sections[0] = Section(first.length_m, math.degrees(float(end.azimuth[0]) + math.pi) % 360.0,
                          first.elevation_deg, first.curvature_1pm, first.curvature_end_1pm,
                          first.elevation_end_deg)
    return Track.from_sections(sections, lat=float(end.lat[0]), lon=float(end.lon[0]),
                               h=float(end.h[0]), earth=track.earth)


def chain_tracks(tracks: Sequence[Track]) -> Track:
    """Tracks joined end to start into one: each after the first starts where the previous
    ends (the joint's gap is dropped) with its own start azimuth and elevation (a kink is
    kept)."""
    if not tracks:
        raise TrackError("nothing to chain")
    sections = []
    for track in tracks:
        sections.extend(tail_sections(track, 0.0))
    return Track(tuple(sections), tracks[0].origin, tracks[0].earth)
