"""Points on several tracks at once: `points_on` (the network navigator's hypotheses).

A bank of hypotheses asks, every cycle, for one or two points on each of K tracks (the
netelements or chained routes they are on). `trackmodel.track.Track.at` evaluates one
track per call, about a hundred small NumPy operations whatever the number of points:
K tracks cost K times that. `points_on` does the per-track part only where it must
(validating ``s``, finding its section and, on integrated sections, its Chebyshev chunk)
and everything else once for all the points: the loxodrome positions, the section
angles, the tangent frame and the ECEF positions, over the section tables of the K tracks
stacked (`TrackStack`, kept for the next cycle asking for the same tracks). The arithmetic
of each point is `Track.at`'s, element by element: the same numbers
(`tests/trackmodel/test_network_points.py` compares them bit for bit).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from trackmodel.earth import geodetic_to_ecef
from trackmodel.loxodrome import loxodrome_position
from trackmodel.sections import SectionArrays, tangent_frame

__all__ = ["points_on", "TrackStack", "StackPoint"]

Array = npt.NDArray[np.float64]

#: Stacks of tracks kept (then forgotten together).
MAX_STACKS = 64

_STACKS: dict[tuple[int, ...], "TrackStack"] = {}


class StackPoint:
    """One point of `points_on`: the fields of `trackmodel.track.TrackPoint` the
    navigator uses (scalars; vectors of 3)."""

    __slots__ = ("s", "lat", "lon", "h", "r_e", "u_n", "azimuth", "elevation")

    def __init__(self, values: dict, m: int) -> None:
        for name in self.__slots__:
            setattr(self, name, values[name][m])


class TrackStack:
    """The section tables of several tracks, stacked (module docstring).

    Parameters
    ----------
    tracks : sequence of trackmodel.track.Track
        On one ellipsoid.

    Notes
    -----
    Reads the tracks' section tables and section starts (``table``, ``starts``) and asks
    their Chebyshev chunks (``Track._chunks``) for positions on integrated sections.
    """

    def __init__(self, tracks) -> None:
        self.tracks = tuple(tracks)
        self.earth = self.tracks[0].earth
        tables = [t.table for t in self.tracks]
        self.first = np.cumsum([0] + [len(t.sections) for t in self.tracks])[:-1]
        self.table = SectionArrays(*(np.concatenate([getattr(tab, name) for tab in tables])
                                     for name in ("s_start", "length", "azimuth0",
                                                  "elevation0", "elevation1", "curvature0",
                                                  "curvature1")))
        self.starts = np.concatenate([t.starts[:-1] for t in self.tracks])
        self.is_loxodrome = self.table.is_loxodrome

    def points(self, which: list[int], s: list[float]) -> dict[str, Array]:
        """Fields (`StackPoint`) at ``s[k]`` on track ``which[k]``, shape (N,) or (N, 3)."""
        which_a = np.asarray(which)
        flat = np.empty(len(s))
        k = np.empty(len(s), dtype=np.intp)
        lat, lon, h = np.empty(len(s)), np.empty(len(s)), np.empty(len(s))
        chunked = []
        for m in sorted(set(which)):                      # per track: s checked, section
            at = np.flatnonzero(which_a == m)
            track = self.tracks[m]
            s_m = track.check_s(np.array([s[j] for j in at], dtype=float))
            k_m = track.section_of(s_m)
            flat[at], k[at] = s_m, k_m + self.first[m]
            if not track.table.is_loxodrome[k_m].all():
                chunked.append((m, at))
        lox = self.is_loxodrome[k]
        if lox.any():                                     # all tracks' straights at once
            kl, tab = k[lox], self.table
            lat[lox], lon[lox], h[lox] = loxodrome_position(
                self.starts[kl, 0], self.starts[kl, 1], self.starts[kl, 2],
                azimuth=tab.azimuth0[kl], elevation=tab.elevation0[kl],
                t=flat[lox] - tab.s_start[kl], earth=self.earth)
        for m, at in chunked:                             # per track: its Chebyshev chunks
            part = at[~lox[at]]
            lat[part], lon[part], h[part] = self.tracks[m]._chunks.position(flat[part])
        ang = self.table.angles(k, flat - self.table.s_start[k])
        u, _, _ = tangent_frame(ang["A"], ang["E"], ang["dA"], ang["dE"], ang["d2A"])
        return {"s": flat, "lat": lat, "lon": lon, "h": h,
                "r_e": geodetic_to_ecef(lat, lon, h, earth=self.earth), "u_n": u,
                "azimuth": ang["A"], "elevation": ang["E"]}


def points_on(tracks, s) -> list[StackPoint]:
    """The point of ``tracks[k]`` at ``s[k]`` (m) for each k, as `trackmodel.track.Track.at`
    gives it (module docstring; tracks on different ellipsoids: one stack per ellipsoid).

    Parameters
    ----------
    tracks : sequence of trackmodel.track.Track
    s : sequence of float

    Returns
    -------
    list of StackPoint
    """
    earths = {t.earth for t in tracks}
    if len(earths) > 1:
        out: list = [None] * len(tracks)
        for earth in earths:
            at = [k for k, t in enumerate(tracks) if t.earth == earth]
            for k, p in zip(at, points_on([tracks[k] for k in at], [s[k] for k in at])):
                out[k] = p
        return out
    if not len(tracks):
        return []
    distinct: dict[int, int] = {}
    order = []
    for track in tracks:
        if id(track) not in distinct:
            distinct[id(track)] = len(order)
            order.append(track)
    key = tuple(distinct)
    stack = _STACKS.get(key)
    if stack is None or any(a is not b for a, b in zip(stack.tracks, order)):
        stack = TrackStack(order)
        if len(_STACKS) >= MAX_STACKS:
            _STACKS.clear()
        _STACKS[key] = stack
    values = stack.points([distinct[id(t)] for t in tracks], list(s))
    return [StackPoint(values, m) for m in range(len(tracks))]
