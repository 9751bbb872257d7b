"""Checks of a fitted network: what users of network tools hit most, found before a run.

The defects that users of tp-lib and OSRD report most are topological, not geometric:
tracks that touch but are not connected (OSRD issue 5247: "tracks are connected but there
are no switches"), tiny sections that end up isolated (OSRD 8903: a 9-cm way), missing
buffer stops at open ends (OSRD 3719) and duplicated or overlapping objects (OSRD 1752).
`check_network` reports, each as a one-line `Finding` located by netelement or joint:

========================  =======  ===========================================================
what                      level    rule
========================  =======  ===========================================================
gap at a joint            warning  the two ends are more than `GAP_WARN_M` apart
                          error    more than `GAP_ERROR_M`: not a joint at all
near miss                 warning  an unconnected end within `NEAR_M` of another netelement's
                                   end: probably a missing netrelation
open ends                 warning  one line listing the unconnected ends (buffer stops, or
                                   the extract's border)
duplicate                 error    two netelements whose ends coincide (either way round)
                                   within the tolerance and whose points lie within it of
                                   each other
short netelement          warning  shorter than the fit tolerance: its direction is not set
                                   by its own points
kink at a navigable joint warning  above `KINK_WARN_DEG`: no train turns that; route lines
                                   through it are refused
========================  =======  ===========================================================
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from trackmodel.fit_defaults import DEFAULT_TOL_M
from trackmodel.network import END, START, Network

__all__ = ["Finding", "check_network", "GAP_WARN_M", "GAP_ERROR_M", "NEAR_M", "KINK_WARN_DEG"]

#: A joint whose ends are farther apart than this is reported, m (two fits, each within
#: the 0.5-m tolerance of the same node).
GAP_WARN_M = 2 * DEFAULT_TOL_M
#: ... and is no joint at all beyond this, m.
GAP_ERROR_M = 10.0
#: An unconnected end this close to another netelement's end is a near miss, m.
NEAR_M = 2.0
#: A navigable joint turning more than this is reported, deg (switches: 3-12°).
KINK_WARN_DEG = 30.0
#: Open ends listed by name in the one warning about them.
LISTED_ENDS = 8
#: Points per netelement compared for duplicates.
DUPLICATE_SAMPLES = 20


@dataclass(frozen=True)
class Finding:
    """One result of `check_network`: ``level`` ("error" or "warning"), ``where`` (a
    netelement, a joint ``A[1]-B[0]``, or "network") and ``what``."""

    level: str
    where: str
    what: str

    def __str__(self) -> str:
        return f"{self.where}: {self.what}"


def _end_name(element: str, end: int) -> str:
    return f"{element}[{end}]"


def check_network(network: Network, *, tol_m: float = DEFAULT_TOL_M) -> list[Finding]:
    """Every finding of the module docstring's table, errors first.

    Parameters
    ----------
    network : Network
    tol_m : float
        The netelements' fit tolerance, m.
    """
    ends = _ends(network)
    found = _joint_findings(network) + _open_end_findings(network, ends)
    found += _duplicates(network, ends, tol_m)
    for name, track in network.elements.items():
        if track.length_m < tol_m:
            found.append(Finding("warning", name, f"{track.length_m:.2f} m long, shorter than "
                                 f"the fit tolerance {tol_m:g} m"))
    return sorted(found, key=lambda f: f.level != "error")


def _ends(network: Network) -> dict[tuple[str, int], np.ndarray]:
    """ECEF position of every netelement end, m."""
    out = {}
    for name, track in network.elements.items():
        points = track.at(np.array([0.0, track.length_m])).r_e
        out[(name, START)], out[(name, END)] = points[0], points[1]
    return out


def _joint_findings(network: Network) -> list[Finding]:
    found = []
    for c in network.connections:
        where = f"{_end_name(c.a, c.a_end)}-{_end_name(c.b, c.b_end)}"
        if c.gap_m > GAP_ERROR_M:
            found.append(Finding("error", where, f"its ends are {c.gap_m:.1f} m apart: not a "
                                 "joint"))
        elif c.gap_m > GAP_WARN_M:
            found.append(Finding("warning", where, f"its ends are {c.gap_m:.2f} m apart"))
        kink = math.degrees(c.kink_rad)
        if c.navigability != "none" and kink > KINK_WARN_DEG:
            found.append(Finding("warning", where, f"a {kink:.1f}° kink at a navigable joint: "
                                 "no train turns that, route lines through it are refused"))
    return found


def _open_end_findings(network: Network, ends) -> list[Finding]:
    joined = {(c.a, c.a_end) for c in network.connections} | {
        (c.b, c.b_end) for c in network.connections}
    open_ends = [e for e in ends if e not in joined]
    if not open_ends:
        return []
    from scipy.spatial import cKDTree
    keys = list(ends)
    tree = cKDTree(np.array([ends[k] for k in keys]))
    found = []
    for end in open_ends:
        for i in tree.query_ball_point(ends[end], NEAR_M):
            other = keys[i]
            if other[0] != end[0]:
                gap = float(np.linalg.norm(ends[end] - ends[other]))
                found.append(Finding("warning", _end_name(*end), f"{gap:.2f} m from "
                                     f"{_end_name(*other)} but not connected: a missing "
                                     "netrelation?"))
                break
    names = ", ".join(_end_name(*e) for e in open_ends[:LISTED_ENDS])
    more = f" and {len(open_ends) - LISTED_ENDS} more" if len(open_ends) > LISTED_ENDS else ""
    found.append(Finding("warning", "network", f"{len(open_ends)} unconnected end(s) (buffer "
                         f"stops or the extract's border): {names}{more}"))
    return found


def _duplicates(network: Network, ends, tol_m: float) -> list[Finding]:
    """Pairs of netelements whose ends coincide within `tol_m` (same or swapped) and whose
    sampled points lie within `tol_m` of each other."""
    from scipy.spatial import cKDTree
    keys = list(ends)
    tree = cKDTree(np.array([ends[k] for k in keys]))
    found, seen = [], set()
    for a in network.elements:
        for i in tree.query_ball_point(ends[(a, START)], tol_m):
            b, b_end = keys[i]
            other = ends[(b, END if b_end == START else START)]
            pair = tuple(sorted((a, b)))
            if (b == a or pair in seen
                    or np.linalg.norm(ends[(a, END)] - other) > tol_m):
                continue
            seen.add(pair)
            if _within(network.elements[a], network.elements[b], tol_m):
                found.append(Finding("error", ", ".join(pair), "the two netelements coincide "
                                     f"within {tol_m:g} m: duplicates"))
    return found


def _within(a, b, tol_m: float) -> bool:
    lat, lon, _ = a.geodetic(np.linspace(0.0, a.length_m, DUPLICATE_SAMPLES))
    proj = b.project(lat, lon)
    return bool(np.max(np.hypot(proj.cross_track_m, proj.along_m)) <= tol_m)
