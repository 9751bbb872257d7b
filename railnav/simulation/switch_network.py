r"""A synthetic track network with many switches and parallel tracks, for switch studies.

`switch_network` builds a double line: track ``A`` and, `SwitchNetworkSpec.spacing_m` to
its left all the way, track ``B`` (one netelement, no switches). Along ``A`` there are
`SwitchNetworkSpec.loops` passing loops on its right: at each loop's first switch a
branch ``L<k>`` leaves ``A`` through an S-curve of two arcs of radius
`SwitchNetworkSpec.turnout_radius_m` (a turnout's diverging curve and its reverse), runs
parallel to ``A`` at the same spacing, and comes back through the mirrored S-curve at the
loop's second switch. So each loop has two switches, and a train on a route that takes
the loop is on a track 4.5 m from ``A`` (and 9 m from ``B``) in between. Between loops
``A`` (and ``B``, concentric) runs through an arc, alternately right and left.

Netelements: ``A0`` (lead-in), then per loop ``A<2k+1>`` (the straight past loop k) and
``A<2k+2>`` (the arc after it), ``L<k>`` and ``B``. Connections: the trailing element of
each switch to both of its ways (``both``), and the two ways of a switch to each other
``none`` (they touch; no train passes between them). Every joint is tangent-continuous
and the ways of a route chained (`trackmodel.network.chain_tracks`) are exact, so a
simulated trip along a route (`route_track`) runs on exactly the netelements' geometry.
Arcs and straights only, so ``B`` (each section's curvature ``κ/(1 + κd)`` over
``L(1 + κd)``, the same centre) is exactly parallel in the plane.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.network import END, START, Connection, Network, chain_tracks
from trackmodel.sections import Section
from trackmodel.track import Track

__all__ = ["SwitchNetworkSpec", "switch_network", "loop_route", "route_track"]


@dataclass(frozen=True)
class SwitchNetworkSpec:
    """The shape of `switch_network`'s double line (module docstring).

    Parameters
    ----------
    loops : int
        Passing loops (two switches each), >= 1.
    spacing_m : float
        Distance between parallel tracks, m.
    turnout_radius_m : float
        Radius of the arcs of each S-curve, m.
    loop_parallel_m : float
        Length of a loop's part parallel to ``A``, m.
    lead_in_m : float
        Straight ``A0`` before the first loop, m.
    between_m, between_radius_m : float
        Length and radius of the arcs of ``A`` between loops, m.
    lat_deg, lon_deg, azimuth_deg : float
        Start of ``A`` and its azimuth (degrees clockwise from north).
    """

    loops: int = 10
    spacing_m: float = 4.5
    turnout_radius_m: float = 500.0
    loop_parallel_m: float = 300.0
    lead_in_m: float = 200.0
    between_m: float = 400.0
    between_radius_m: float = 1500.0
    lat_deg: float = 50.9
    lon_deg: float = 4.5
    azimuth_deg: float = 80.0

    @property
    def turnout_angle_rad(self) -> float:
        """Angle of each arc of an S-curve: ``2R(1 − cos θ) = spacing``."""
        return math.acos(1.0 - self.spacing_m / (2.0 * self.turnout_radius_m))


def _track_at(line: Track, s: float, sections) -> Track:
    """A track of `sections` starting at point `s` of `line`, with its azimuth."""
    p = line.at(s)
    first = sections[0]
    head = Section(first.length_m, math.degrees(float(p.azimuth)) % 360.0, 0.0,
                   first.curvature_1pm)
    return Track.from_sections([head, *sections[1:]], lat=float(p.lat), lon=float(p.lon),
                               earth=line.earth)


def _line_a(spec: SwitchNetworkSpec) -> tuple[list[list[Section]], Track]:
    """The sections of each ``A`` element, and ``A`` as one track."""
    theta, R = spec.turnout_angle_rad, spec.turnout_radius_m
    beside = 4.0 * R * math.sin(theta) + spec.loop_parallel_m
    parts = [[Section(spec.lead_in_m, spec.azimuth_deg, 0.0, 0.0)]]
    for k in range(spec.loops):
        parts.append([Section(beside, None, 0.0, 0.0)])
        sign = 1.0 if k % 2 == 0 else -1.0
        parts.append([Section(spec.between_m, None, 0.0, sign / spec.between_radius_m)])
    flat = [s for part in parts for s in part]
    line = Track.from_sections(flat, lat=math.radians(spec.lat_deg),
                               lon=math.radians(spec.lon_deg))
    return parts, line


def _loop_sections(spec: SwitchNetworkSpec) -> list[Section]:
    theta, R = spec.turnout_angle_rad, spec.turnout_radius_m
    arc = R * theta
    return [Section(arc, 0.0, 0.0, 1.0 / R), Section(arc, None, 0.0, -1.0 / R),
            Section(spec.loop_parallel_m, None, 0.0, 0.0),
            Section(arc, None, 0.0, -1.0 / R), Section(arc, None, 0.0, 1.0 / R)]


def _line_b(spec: SwitchNetworkSpec, line: Track) -> Track:
    """``B``: every section of ``A`` offset `spacing_m` to its left (module docstring)."""
    d = -spec.spacing_m            # curvature > 0 turns right; left is the outside then
    sections = []
    for k, sec in enumerate(line.sections):
        kappa = sec.curvature_1pm
        sections.append(Section(sec.length_m * (1.0 - kappa * d) if kappa else sec.length_m,
                                sec.azimuth_deg if k == 0 else None, 0.0,
                                kappa / (1.0 - kappa * d) if kappa else 0.0))
    p = line.at(0.0)
    A = float(p.azimuth)
    left_n = -spec.spacing_m * np.array([math.cos(A), -math.sin(A), 0.0])
    lat, lon, _ = ecef_to_geodetic(np.asarray(p.r_e) + C_n_e(float(p.lat), float(p.lon))
                                   @ left_n)
    return Track.from_sections(sections, lat=float(lat), lon=float(lon), earth=line.earth)


def switch_network(spec: SwitchNetworkSpec = SwitchNetworkSpec()) -> Network:
    """The double line with passing loops (module docstring)."""
    parts, line = _line_a(spec)
    elements, starts, s = {}, [], 0.0
    for k, part in enumerate(parts):
        starts.append(s)
        elements[f"A{k}"] = _track_at(line, s, part)
        s += sum(sec.length_m for sec in part)
    connections = []
    loop = _loop_sections(spec)
    for k in range(spec.loops):
        before, beside, after, name = f"A{2 * k}", f"A{2 * k + 1}", f"A{2 * k + 2}", f"L{k}"
        elements[name] = _track_at(line, starts[2 * k + 1], loop)
        connections += [Connection(before, END, beside, START),
                        Connection(before, END, name, START),
                        Connection(beside, START, name, START, "none"),
                        Connection(beside, END, after, START),
                        Connection(name, END, after, START),
                        Connection(beside, END, name, END, "none")]
    elements["B"] = _line_b(spec, line)
    return Network(elements, connections)


def loop_route(spec: SwitchNetworkSpec, takes: "list[bool] | tuple[bool, ...]"
               ) -> tuple[tuple[str, int], ...]:
    """The legs of the route along ``A`` that takes loop k where ``takes[k]``."""
    if len(takes) != spec.loops:
        raise ValueError(f"give one choice per loop ({spec.loops}), got {len(takes)}")
    legs = [("A0", 1)]
    for k, take in enumerate(takes):
        legs += [(f"L{k}" if take else f"A{2 * k + 1}", 1), (f"A{2 * k + 2}", 1)]
    return tuple(legs)


def route_track(network: Network, legs) -> Track:
    """The route's netelements chained exactly (tangent-continuous joints: no refit)."""
    return chain_tracks([network.elements[e] for e, _ in legs])
