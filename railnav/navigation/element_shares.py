r"""On which netelement a hypothesis's train is: its Gaussian along ``s`` shared out.

A hypothesis says "the train is at ``s`` (σ_s) along my track". Its track is a chain of
oriented element stretches (`railnav.navigation.hypotheses.Hypothesis.pieces`), so the
probability that the train is on element E is the Gaussian's mass over E's stretch. At a
joint the mean passes before the train does half the time: a fix-only hypothesis branches
(`railnav.navigation.hypotheses.branch`) as soon as its mean leaves its element, and
each child then holds ``Φ(−d/σ_s)`` of its probability *before* its own element's start
(``d``: how far its mean is past the joint), i.e. on the element it came from.
`element_shares` gives each element its part:

* each piece of the hypothesis's track: ``Φ((b − s)/σ_s) − Φ((a − s)/σ_s)`` over its
  stretch ``[a, b]``;
* before the first piece: that piece's own element when the piece starts inside it (a
  tail kept behind a joint), else the element the hypothesis's path came through (its
  ``path``; a start has none: then the first piece);
* beyond the last piece's end: that end's navigable successors, evenly (the prior of a
  switch's ways, as `branch` gives it); a buffer stop has none: then the last piece.

Measured (`benchmarks/bench_network_brussels.py`, log_28554 degraded, seeds 3 and 4):
at 61.6 s the train is 3.6 m before the end of 88_L_2026 and the one hypothesis's mean
0.35 / 0.12 m past it (σ_s 1.5 m), branched into 88_L_42 and 88_L_7855 (0.5 each): by
the mean the netelement is a way (wrong), by the mass 88_L_2026 (0.41 / 0.47 against
0.30 / 0.27 each way).
"""
from __future__ import annotations

import math

__all__ = ["element_shares"]

_SQRT2 = math.sqrt(2.0)


def _came_from(path: tuple, key: tuple) -> tuple | None:
    """``(element, orientation)`` the path went through just before it entered `key`
    the last time (None: it started there)."""
    for i in range(len(path) - 1, 0, -1):
        if tuple(path[i][:2]) == key:
            return tuple(path[i - 1][:2])
    return None


def element_shares(h, tracks) -> list[tuple[str, int, float, float]]:
    """Where `h`'s position lies (module docstring).

    Parameters
    ----------
    h : railnav.navigation.hypotheses.Hypothesis
    tracks : railnav.navigation.net_tracks.OrientedTracks

    Returns
    -------
    list of (str, int, float, float)
        ``(element, orientation, share, s_m)``: the share of `h`'s probability on each
        element (summing to 1; an element may appear more than once), and the point of
        its stretch nearest the mean (``s`` along the oriented element, m).
    """
    i_s = h.index("s")
    s, sigma = h.s_m, math.sqrt(max(float(h.P[i_s, i_s]), 0.0))

    def below(x: float) -> float:            # P(S < x)
        if sigma == 0.0:
            return float(s < x)
        return 0.5 * math.erfc((s - x) / (sigma * _SQRT2))

    starts = (0.0,) + tuple(h.ends[:-1])
    out = []
    for j, ((element, orientation, start), a, b) in enumerate(zip(h.pieces, starts, h.ends)):
        lo = 0.0 if j == 0 else below(a)
        hi = 1.0 if j == len(h.pieces) - 1 else below(b)
        out.append([element, orientation, hi - lo, start + min(max(s - a, 0.0), b - a)])
    first, last = out[0], out[-1]
    before = below(0.0)
    prev = None if h.pieces[0][2] > 0.0 else _came_from(h.path, tuple(h.pieces[0][:2]))
    if prev is not None and before > 0.0:
        first[2] -= before
        out.append([prev[0], prev[1], before, tracks.length_m(prev[0])])
    ways = tracks.network.successors(last[0], last[1])
    after = 1.0 - below(h.ends[-1])
    if ways and after > 0.0:
        last[2] -= after
        out.extend([e, o, after / len(ways), 0.0] for e, o in ways)
    return [(e, int(o), float(p), float(x)) for e, o, p, x in out]
