"""The tracks the hypotheses of a network run live on: netelements, oriented, and chained
across a joint ahead.

A hypothesis of the network navigator (`railnav.navigation.network_navigator`) runs one
filter on one track, made of *pieces*: ``(element, orientation, start_m)``, the oriented
netelement from ``start_m`` to its end (orientation ``+1``: the element's own track, ``s``
from its first coordinate; ``-1``: its reversal, `trackmodel.network.reversed_track`,
``s' = L − s``, exact in the track model). Usually one whole piece (``start_m = 0``): the
hypothesis is on that element. An inertial hypothesis nearing a switch branches *before*
it (`railnav.navigation.hypotheses.branch_ahead`): each child then runs on the parent's
remaining stretch chained to one of the ways (`trackmodel.network.chain_tracks`; the
siblings share that stretch exactly), so the curvature of its way is in its track model
before the vehicle gets there; once past the joint it drops the stretch behind
(`railnav.navigation.hypotheses.rebased`).

The filter's ``s`` is along the chained track and its speed is signed, so the direction of
travel on an element is ``orientation × sign(v)``. `OrientedTracks` builds each track once,
locates a hypothesis's ``s`` on its netelement (`locate`: the element, orientation and
``s`` on the oriented element; ``offset_m`` from the element's first coordinate is what
``estimates.csv`` reports as ``netelement_offset_m``), lists the kinked joints along a
track (`joints`) and where a hypothesis continues past the end of its track (`leaving`:
each navigable successor of the last piece, ``s − L`` along it; before its start, a train
backing, each predecessor of the first piece at its end, ``L_pred + s``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackmodel.network import END, START, Network, chain_tracks
from trackmodel.network_lines import TRANSITION_MAX_M, tail_sections
from trackmodel.track import Track

__all__ = ["OrientedTracks", "Passage", "track_tail", "bare", "GAP_CURVE_M"]

#: The stretch over which a joint's gap is taken to be closed by the real track, m (a
#: route line's transition: `trackmodel.network_lines.TRANSITION_MAX_M`).
GAP_CURVE_M = TRANSITION_MAX_M

@dataclass(frozen=True)
class Passage:
    """Where a hypothesis continues across a joint: the element and orientation it enters
    and its ``s`` there, m."""

    element: str
    orientation: int
    s_m: float


def bare(element: str, orientation: int) -> tuple[tuple[str, int, float], ...]:
    """The pieces of a hypothesis on the whole of one oriented element."""
    return ((element, int(orientation), 0.0),)


def track_tail(track: Track, s0: float) -> Track:
    """The part of `track` from ``s0`` to its end, as a track of its own
    (`trackmodel.network_lines.tail_sections`, from the point at ``s0``)."""
    if s0 <= 0.0:
        return track
    p = track.at(s0)
    return Track.from_sections(tail_sections(track, s0), lat=float(p.lat), lon=float(p.lon),
                               h=float(p.h), earth=track.earth)


class OrientedTracks:
    """The tracks of a network's hypotheses, built on first use (module docstring).

    Parameters
    ----------
    network : trackmodel.network.Network
    """

    def __init__(self, network: Network) -> None:
        self.network = network
        self._tracks: dict[tuple, Track] = {}
        self._kinks: dict[tuple[str, int], float] | None = None
        #: `piece_ends` and `joints` of each chained track asked for
        self._ends: dict[tuple, np.ndarray] = {}
        self._joints: dict[tuple, tuple] = {}

    def track(self, element: str, orientation: int) -> Track:
        """The track of `element` travelled in `orientation` (+1 its own, -1 reversed)."""
        key = (element, int(orientation))
        if key not in self._tracks:
            self._tracks[key] = self.network.oriented(element, orientation)
        return self._tracks[key]

    def placed(self, pieces) -> Track:
        """The chained track of a hypothesis's pieces (module docstring)."""
        pieces = tuple(pieces)
        if len(pieces) == 1 and pieces[0][2] == 0.0:
            return self.track(pieces[0][0], pieces[0][1])
        if pieces not in self._tracks:
            parts = [track_tail(self.track(e, o), start) for e, o, start in pieces]
            self._tracks[pieces] = chain_tracks(parts)
        return self._tracks[pieces]

    def length_m(self, element: str) -> float:
        """Length of `element`, m."""
        return self.network.length_m(element)

    def piece_ends(self, pieces) -> np.ndarray:
        """``s`` of the end of each piece along the chained track, m (read-only; computed
        once per chained track: a hypothesis asks every cycle, `leaving`)."""
        key = tuple(pieces)
        ends = self._ends.get(key)
        if ends is None:
            ends = np.cumsum([self.length_m(e) - start for e, _, start in key])
            ends.flags.writeable = False
            self._ends[key] = ends
        return ends

    def locate(self, pieces, s_m: float) -> tuple[str, int, float]:
        """The piece a point ``s_m`` of the chained track is on: its element, orientation
        and ``s`` on the oriented element (beyond either end: on the first or last)."""
        ends = self.piece_ends(pieces)
        j = int(min(np.searchsorted(ends, s_m), len(pieces) - 1))
        element, orientation, start = pieces[j]
        before = float(ends[j - 1]) if j else 0.0
        return element, orientation, start + s_m - before

    def offset_m(self, element: str, orientation: int, s_m):
        """Distance from the element's first coordinate of the point ``s_m`` along its
        oriented track, m (array or float)."""
        return s_m if orientation == 1 else self.length_m(element) - s_m

    def s_of_offset(self, element: str, orientation: int, offset_m):
        """The oriented track's ``s`` of a point `offset_m` from the element's first
        coordinate, m (the inverse of `offset_m`)."""
        return offset_m if orientation == 1 else self.length_m(element) - offset_m

    def _end_kink(self, element: str, end: int) -> float:
        """The largest kink at an element's end, rad; a joint's gap counts as the kink of
        the S-curve that closes it over `GAP_CURVE_M` (``4 g / l``)."""
        if self._kinks is None:
            self._kinks = {}
            for c in self.network.connections:
                if c.navigability == "none" or not np.isfinite(c.kink_rad):
                    continue
                kink = max(float(c.kink_rad), 4.0 * float(np.nan_to_num(c.gap_m)) / GAP_CURVE_M)
                for key in ((c.a, c.a_end), (c.b, c.b_end)):
                    self._kinks[key] = max(self._kinks.get(key, 0.0), kink)
        return self._kinks.get((element, end), 0.0)

    def joints(self, pieces) -> list[tuple[float, float]]:
        """``(s_m, kink_rad)`` of the joints along a chained track: its start (a whole
        first piece), between its pieces, and its end; the largest kink of the navigable
        connections at each (`_end_kink`); computed once per chained track."""
        key = tuple(pieces)
        if key not in self._joints:
            self._joints[key] = tuple(self._joints_of(key))
        return list(self._joints[key])

    def _joints_of(self, pieces) -> list[tuple[float, float]]:
        """`joints` computed."""
        out = []
        ends = self.piece_ends(pieces)
        e0, o0, start0 = pieces[0]
        if start0 == 0.0:
            out.append((0.0, self._end_kink(e0, START if o0 == 1 else END)))
        for (e, o, _), s_end in zip(pieces, ends):
            out.append((float(s_end), self._end_kink(e, END if o == 1 else START)))
        return out

    def leaving(self, pieces, s_m: float) -> list[Passage] | None:
        """Where a hypothesis at ``s_m`` continues (module docstring): None while on its
        track; an empty list at a buffer stop (no navigable passage)."""
        length = float(self.piece_ends(pieces)[-1])
        if 0.0 <= s_m <= length:
            return None
        if s_m > length:
            element, orientation, _ = pieces[-1]
            return [Passage(e, d, s_m - length)
                    for e, d in self.network.successors(element, orientation)]
        element, orientation, start = pieces[0]
        if start > 0.0:                       # backing off a chained stretch's start
            return [Passage(element, orientation, start + s_m)]
        return [Passage(e, d, self.length_m(e) + s_m)
                for e, d in self.network.predecessors(element, orientation)]
