"""Which netelement a recorded position is on, where that is unambiguous, and scores.

`netelement_truth` is issue 13's definition of the truth of a real log: a position (a
carrier-fixed fix) is on netelement E when E is the nearest netelement, within
`TRUTH_WITHIN_M`, and every other netelement is at least `TRUTH_OTHERS_M` away (near a
switch the branches are closer than that: no truth there). Distances are horizontal
and perpendicular (`trackmodel.network.Network.project`: a point beyond an element's
ends is not near that element).

`netelement_scores` compares a run's per-epoch netelement with such a truth, and
`route_passes` checks that a route (a netelement sequence) is a path the network allows
and passes, in order, the netelements the truth names.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["netelement_truth", "netelement_scores", "route_passes", "collapse",
           "TRUTH_WITHIN_M", "TRUTH_OTHERS_M"]

#: The nearest netelement must be this close, m.
TRUTH_WITHIN_M = 2.5
#: Every other netelement must be at least this far, m.
TRUTH_OTHERS_M = 4.0


def netelement_truth(network, lat: npt.ArrayLike, lon: npt.ArrayLike, *,
                     within_m: float = TRUTH_WITHIN_M, others_m: float = TRUTH_OTHERS_M
                     ) -> np.ndarray:
    """The netelement each point is unambiguously on (module docstring), else None.

    Parameters
    ----------
    network : trackmodel.network.Network
    lat, lon : array_like, shape (N,)
        rad.

    Returns
    -------
    ndarray of object, shape (N,)
    """
    lat, lon = np.atleast_1d(np.asarray(lat, float)), np.atleast_1d(np.asarray(lon, float))
    out = np.full(lat.size, None, dtype=object)
    near = network.project(lat, lon, radius_m=max(within_m, others_m))
    for point, rows in near.groupby("point"):
        d = rows["distance_m"].to_numpy()
        if d[0] <= within_m and (d.size == 1 or d[1] >= others_m):
            out[int(point)] = rows["element"].iloc[0]
    return out


def netelement_scores(time_s: npt.ArrayLike, element: npt.ArrayLike,
                      probability: npt.ArrayLike, truth_time_s: npt.ArrayLike,
                      truth: npt.ArrayLike, *, level: float = 0.99,
                      tol_s: float = 1e-3) -> dict:
    """A run's netelement against a truth at the truth's epochs.

    Parameters
    ----------
    time_s, element, probability : array_like, shape (C,)
        The run's per-cycle netelement and its probability.
    truth_time_s, truth : array_like, shape (N,)
        The truth's times and netelements (None: no truth there).
    level : float
        The confidence of the ``confident_*`` figures.
    tol_s : float
        A truth epoch is scored when a cycle ends within this, s.

    Returns
    -------
    dict
        ``epochs`` (with a truth and a cycle), ``right``, ``share_right``, ``confident``
        (epochs with probability >= `level`), ``confident_right``, ``share_confident_right``.
    """
    t = np.asarray(time_s, float)
    el = np.asarray(element, dtype=object)
    prob = np.asarray(probability, float)
    tt = np.asarray(truth_time_s, float)
    tr = np.asarray(truth, dtype=object)
    has = np.array([x is not None for x in tr], dtype=bool)
    k = np.clip(np.searchsorted(t, tt), 0, max(t.size - 1, 0))
    k_prev = np.clip(k - 1, 0, None)
    k = np.where(np.abs(t[k_prev] - tt) < np.abs(t[k] - tt), k_prev, k) if t.size else k
    ok = has & (np.abs(t[k] - tt) <= tol_s) if t.size else np.zeros(tt.size, bool)
    right = ok & (el[k] == tr)
    sure = ok & (prob[k] >= level)
    n, n_sure = int(ok.sum()), int(sure.sum())
    return {"epochs": n, "right": int(right.sum()),
            "share_right": float(right.sum() / n) if n else None,
            "confident": n_sure, "confident_right": int((sure & right).sum()),
            "share_confident_right": float((sure & right).sum() / n_sure) if n_sure else None}


def collapse(sequence) -> list:
    """The sequence without repeats of consecutive items (None items dropped)."""
    out: list = []
    for item in sequence:
        if item is not None and (not out or out[-1] != item):
            out.append(item)
    return out


def _passage(network, a, b) -> bool:
    """Whether a train passes from leg `a` to leg `b`: forwards (``b`` a successor of
    ``a``), or backing (both travelled the other way, ``b`` is a successor of ``a``)."""
    return b in network.successors(*a) or \
        (b[0], -b[1]) in network.successors(a[0], -a[1])


def route_passes(network, legs, truth_elements) -> dict:
    """Whether a route is a path the network allows and passes the truth's netelements.

    Parameters
    ----------
    network : trackmodel.network.Network
    legs : sequence of (element, orientation)
        The route in order (orientation +1 / -1: on the element's own track or its
        reversal).
    truth_elements : sequence of str
        Netelements the truth names, in order (`collapse` of a truth).

    Returns
    -------
    dict
        ``navigable`` (every consecutive pair of legs is a passage, forwards or
        backing), ``passes_truth``
        (the truth's elements are a subsequence of the route's), ``missing`` (the truth's
        elements not matched, in order).
    """
    legs = [(e, int(o)) for e, o in legs]
    navigable = all(_passage(network, a, b) for a, b in zip(legs[:-1], legs[1:]))
    route = [e for e, _ in legs]
    missing, pos = [], 0
    for e in truth_elements:
        try:
            pos = route.index(e, pos) + 1
        except ValueError:
            missing.append(e)
    return {"navigable": bool(navigable), "passes_truth": not missing, "missing": missing}
