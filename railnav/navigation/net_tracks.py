"""Netelements as the tracks the hypotheses of a network run live on.

A hypothesis of the network navigator (`railnav.navigation.network_navigator`) runs on one
netelement in one *orientation*: ``+1`` on the element's own track (``s`` from its first
coordinate), ``-1`` on its reversal (`trackmodel.network.reversed_track`: ``s' = L − s``,
exact in the track model). Its filter's ``s`` is along that oriented track and its speed
is signed, so the train's direction of travel on the element is ``orientation ×
sign(v)``. `OrientedTracks` builds each oriented track once and converts between a
hypothesis's ``s`` and the offset from the element's first coordinate (what
``estimates.csv`` reports as ``netelement_offset_m``).

Where a hypothesis leaves its element (`leaving`): past the end of its oriented track
(``s > L``) it enters each successor of ``(element, orientation)`` at that successor's
start, ``s − L`` along it; before the start (``s < 0``, a train backing) it enters each
predecessor at its end, ``L_pred + s`` along it (`trackmodel.network.Network.successors`
/ ``predecessors``: the navigable passages only).
"""
from __future__ import annotations

from dataclasses import dataclass

from trackmodel.network import Network, reversed_track
from trackmodel.track import Track

__all__ = ["OrientedTracks", "Passage"]


@dataclass(frozen=True)
class Passage:
    """Where a hypothesis continues across a joint: the element and orientation it enters
    and its ``s`` there, m."""

    element: str
    orientation: int
    s_m: float


class OrientedTracks:
    """The oriented tracks of a network, built on first use.

    Parameters
    ----------
    network : trackmodel.network.Network
    """

    def __init__(self, network: Network) -> None:
        self.network = network
        self._tracks: dict[tuple[str, int], Track] = {}

    def track(self, element: str, orientation: int) -> Track:
        """The track of `element` travelled in `orientation` (+1 its own, -1 reversed)."""
        key = (element, int(orientation))
        if key not in self._tracks:
            own = self.network.elements[element]
            self._tracks[key] = own if orientation == 1 else reversed_track(own)
        return self._tracks[key]

    def length_m(self, element: str) -> float:
        """Length of `element`, m."""
        return self.network.length_m(element)

    def offset_m(self, element: str, orientation: int, s_m):
        """Distance from the element's first coordinate of the point ``s_m`` along its
        oriented track, m (array or float)."""
        return s_m if orientation == 1 else self.length_m(element) - s_m

    def s_of_offset(self, element: str, orientation: int, offset_m):
        """The oriented track's ``s`` of a point `offset_m` from the element's first
        coordinate, m (the inverse of `offset_m`)."""
        return offset_m if orientation == 1 else self.length_m(element) - offset_m

    def leaving(self, element: str, orientation: int, s_m: float) -> list[Passage] | None:
        """Where a hypothesis at ``s_m`` continues (module docstring): None while
        ``0 <= s_m <= L``; an empty list at a buffer stop (no navigable passage)."""
        length = self.length_m(element)
        if 0.0 <= s_m <= length:
            return None
        if s_m > length:
            return [Passage(e, d, s_m - length)
                    for e, d in self.network.successors(element, orientation)]
        return [Passage(e, d, self.length_m(e) + s_m)
                for e, d in self.network.predecessors(element, orientation)]
