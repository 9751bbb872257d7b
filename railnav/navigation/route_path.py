r"""A hypothesis's path (the netelements it went through) and the route it gives.

Each hypothesis carries its path (`railnav.navigation.hypotheses.Hypothesis.path`), one
`PathEntry` per element it entered, inherited from its ancestors. After each cycle
`entered` appends the element the hypothesis is on when that is a new one, and keeps how
surely it is across the joint it came through: the greatest distance of its mean from
where it entered, in σ_s of the same cycle (``depth_sigmas``; a start, which came through
no joint, is sure: ``inf``).

The path is what happened to a Gaussian's mean, not to the train. A train standing at a
joint, its fix-only mean jittering across it by millimetres, gave a path that goes back
and forth between the joint's two elements (a simulated run on the Brussels network with
RTK fixes: ``88_L_155 > 88_L_111`` five times over in its first 12 s). `route` is the
path with such excursions undone: a visit to Y between two visits to X that never went
`EXCURSION_SIGMAS` σ_s into Y is taken out and the two X visits are one. A train that
goes into Y and comes back (a reversal, ``s`` hundreds of σ_s into Y) keeps X > Y > X.

Why 5 σ_s and not 3: the depth is the greatest over the visit, and a standing train makes
hundreds of visits, so their deepest is the tail of a maximum. Measured (a train standing
3 mm past the 88_L_155/88_L_111 joint, 1-Hz RTK fixes, σ 3 cm, 90 s and 600 s, seeds 1-3:
66-448 visits): the deepest visit 1.56-3.37 σ_s, above 3 in three of the six runs (with 3,
seed 1's 600 s route is 88_L_155 > 88_L_111 > 88_L_155); a train
going 2 m, 10 m and 200 m into the next element and back: 65, 331 and 6681 σ_s. On the
Brussels logs (`benchmarks/bench_network_brussels.py`, as given and degraded, seeds 1-5)
the only visits between two visits to one element were 0.00-0.11 σ_s deep: a degraded
log_28554's hypotheses dead-reckoning through the fix gap at its end (σ_s ~290 m) onto
88_L_11801 and drawn 240 m back by the first fix after it, and a 0.1-s flick of degraded
log_29304 (seed 2) across the 88_L_11648/88_L_127 joint; the 15-min out-and-back run's
reversal on 88_L_9749 was 16748 σ_s deep.

The path itself stays as it was: `railnav.navigation.element_shares` reads where a
hypothesis came from (the probability behind its first piece's start belongs there), and
the per-epoch netelement with it. ``route.csv`` and ``summary.json["route"]``
(`railnav.navigation.network_result`) are the route of the final most probable
hypothesis.
"""
from __future__ import annotations

import math
from typing import NamedTuple

__all__ = ["PathEntry", "entered", "route", "EXCURSION_SIGMAS"]

#: A visit between two visits to one element is an excursion undone (`route`) when its
#: mean never went this many σ_s beyond where it entered.
EXCURSION_SIGMAS = 5.0


class PathEntry(NamedTuple):
    """One element of a path (module docstring).

    Attributes
    ----------
    element : str
    orientation : int
        +1: along the element's coordinates, -1: against them.
    entry_time_s : float
        The end of the cycle that found the hypothesis on it, s.
    entry_m : float
        Where it was found, ``s`` along the oriented element, m.
    depth_sigmas : float
        The greatest ``|s − entry_m| / σ_s`` since, each cycle's σ_s (inf: a start, or
        spawned from a fix: through no joint).
    """

    element: str
    orientation: int
    entry_time_s: float
    entry_m: float = 0.0
    depth_sigmas: float = math.inf


def entered(hyp, time_s: float, *, through_joint: bool = True) -> None:
    """Append to `hyp`'s path the element it is on when that is a new one, else deepen
    its last entry (module docstring).

    Parameters
    ----------
    hyp : railnav.navigation.hypotheses.Hypothesis
    time_s : float
        The cycle's end, s.
    through_joint : bool
        False: a new element was not reached through a joint (a hypothesis spawned from a
        fix, `railnav.navigation.spawning`): sure, as a start is.
    """
    element, orientation, s_on = hyp.where()
    path = hyp.path
    if not path or (path[-1].element, path[-1].orientation) != (element, orientation):
        depth = 0.0 if path and through_joint else math.inf
        hyp.path = path + (PathEntry(element, int(orientation), float(time_s), float(s_on),
                                     depth),)
        return
    last = path[-1]
    if last.depth_sigmas == math.inf:
        return
    i_s = hyp.index("s")
    sigma = math.sqrt(max(float(hyp.P[i_s, i_s]), 0.0))
    depth = abs(s_on - last.entry_m)
    z = depth / sigma if sigma > 0.0 else (math.inf if depth > 0.0 else 0.0)
    if z > last.depth_sigmas:
        hyp.path = path[:-1] + (last._replace(depth_sigmas=z),)


def route(path, *, excursion_sigmas: float = EXCURSION_SIGMAS) -> tuple:
    """`path` with its undone excursions taken out (module docstring).

    Parameters
    ----------
    path : sequence of PathEntry
    excursion_sigmas : float
        A visit that never went this many σ_s deep, between two visits to one element
        and orientation, is taken out.

    Returns
    -------
    tuple of PathEntry
        The visits kept; one made of two keeps the first's entry and the deeper depth.
    """
    out: list = []
    for entry in path:
        if len(out) > 1 and out[-2][:2] == entry[:2] and \
                out[-1].depth_sigmas < excursion_sigmas:
            out.pop()
            out[-1] = out[-1]._replace(depth_sigmas=max(out[-1].depth_sigmas,
                                                        entry.depth_sigmas))
        else:
            out.append(entry)
    return tuple(out)
