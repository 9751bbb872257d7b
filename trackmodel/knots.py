"""Knot placement for piecewise-linear profiles (curvature, elevation) fitted to points.

`refine_knots` splits every knot interval that holds a point outside the tolerance (at
the worst point, or in the middle when that is too close to a knot) until all points are
inside; `prune_knots` then removes knots whose profile value lies close to the line
between its neighbours, keeping a removal only when the refit stays inside the
tolerance. The profile fit itself is a callback, so the horizontal (curvature) and
vertical (elevation) fits share this logic.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

log = logging.getLogger(__name__)

__all__ = ["refine_knots", "prune_knots", "initial_knots", "MIN_KNOT_GAP_M"]

Array = npt.NDArray[np.float64]
#: Fit callback: knots -> (model, point s positions (N,), point residuals (N,), knot values,
#: knots actually used (the callback may move the last one)).
FitFn = Callable[[Array], tuple[Any, Array, Array, Array, Array]]

MIN_KNOT_GAP_M = 0.5
MAX_REFINE_ROUNDS = 40
MAX_PRUNE_FITS = 25


def initial_knots(length_m: float, spacing_m: float) -> Array:
    """Uniform knots over ``[0, length_m]`` at most `spacing_m` apart, m."""
    n = max(1, int(np.ceil(length_m / spacing_m)))
    return np.linspace(0.0, length_m, n + 1)


def _splits(knots: Array, s: Array, r: Array, tol: float, min_gap: float) -> Array:
    """New knots: one per interval holding a point with ``|r| > tol``."""
    bad = np.abs(r) > tol
    new = []
    j = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 2)
    for interval in np.unique(j[bad]):
        inside = bad & (j == interval)
        worst = s[inside][np.argmax(np.abs(r[inside]))]
        a, b = knots[interval], knots[interval + 1]
        if min(worst - a, b - worst) >= min_gap:
            new.append(worst)
        elif b - a >= 2.0 * min_gap:
            new.append(0.5 * (a + b))
    return np.array(new)


def refine_knots(fit: FitFn, knots: Array, tol: float,
                 progress: Callable[[int, int], None] | None = None, *,
                 min_gap_m: float = MIN_KNOT_GAP_M):
    """Add knots until every residual is within `tol`.

    Returns
    -------
    knots : ndarray
    result : tuple
        The last `fit` result.
    """
    result = fit(knots)
    knots = result[4]
    for round_ in range(MAX_REFINE_ROUNDS):
        _, s, r, _, _ = result
        new = _splits(knots, s, r, tol, min_gap_m)
        log.debug("refine round %d: %d knots, max |r| %.3g, %d splits", round_, len(knots),
                  np.abs(r).max(initial=0.0), len(new))
        if progress is not None:
            progress(round_ + 1, MAX_REFINE_ROUNDS)
        if not len(new):
            break
        result = fit(np.unique(np.concatenate([knots, new])))
        knots = result[4]
    return knots, result


def _removal_cost(knots: Array, values: Array) -> Array:
    """For interior knots: effect of replacing the value by the chord of its neighbours."""
    t0, t1, t2 = knots[:-2], knots[1:-1], knots[2:]
    chord = values[:-2] + (values[2:] - values[:-2]) * (t1 - t0) / (t2 - t0)
    return np.abs(values[1:-1] - chord) * (t2 - t0) ** 2 / 8.0


def prune_knots(fit: FitFn, knots: Array, result, tol: float):
    """Remove knots while the refit keeps every residual within `tol`.

    Tries batches of non-adjacent knots in order of increasing removal cost, halving a
    batch that fails, for at most `MAX_PRUNE_FITS` refits.
    """
    keep: set[float] = set()
    fits = 0
    batch_size = max(1, (len(knots) - 2) // 2)
    while fits < MAX_PRUNE_FITS and len(knots) > 2:
        cost = _removal_cost(knots, result[3])
        order = [i + 1 for i in np.argsort(cost) if knots[i + 1] not in keep]
        batch: list[int] = []
        for i in order:
            if all(abs(i - b) > 1 for b in batch):
                batch.append(i)
            if len(batch) >= batch_size:
                break
        if not batch:
            break
        trial = np.delete(knots, batch)
        trial_result = fit(trial)
        fits += 1
        if np.abs(trial_result[2]).max(initial=0.0) <= tol:
            knots, result = trial_result[4], trial_result
            batch_size = max(1, len(batch))
        elif len(batch) == 1:
            keep.add(float(knots[batch[0]]))
        else:
            batch_size = max(1, len(batch) // 2)
    return knots, result
