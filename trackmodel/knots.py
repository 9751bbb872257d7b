"""Adding and removing pieces of a fitted profile until it is within tolerance, and lean.

`refine` inserts, where points are outside the tolerance, a short new piece at the worst
point of each run of such points (an arc horizontally, a vertical curve vertically: the
profile is unchanged at first, the next fit moves the new joints and values) and refits,
until every point is inside or `MAX_REFINE_ROUNDS` pass. `simplify` then tries, in
batches, to replace pieces by simpler ones (a transition with curvature jumps by one tied
to its neighbours; an arc of negligible curvature by a straight) and `prune` to remove
pieces altogether (cheapest first by an estimate of their lateral effect), keeping a
change only when the refit stays inside the tolerance. A failing batch is halved; a single
change that fails is not tried again.

The fits themselves are a callback ``fit(shape, warm) -> result`` (``warm``: the last
accepted result, for a warm start; ``result.shape``, ``result.s``, ``result.residual_m``),
so the horizontal and the vertical fit share this logic.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from trackmodel.pieces import CONST, FREE, RAMP, ZERO, Shape

log = logging.getLogger(__name__)

__all__ = ["refine", "simplify", "prune", "insert_pieces", "remove_piece",
           "MAX_REFINE_ROUNDS", "STALL_ROUNDS"]

Array = npt.NDArray[np.float64]
FitFn = Callable[[Shape, Any], Any]

MAX_REFINE_ROUNDS = 25
#: Refinement stops after this many rounds in a row that did not lower the largest
#: deviation by `STALL_FRACTION` of it.
STALL_ROUNDS = 3
STALL_FRACTION = 0.02
#: Violating points whose indices are at most this far apart form one run.
RUN_GAP_POINTS = 2
#: A flat arc: its curvature moves its middle by less than this fraction of the tolerance.
FLAT_FRACTION = 0.05


def _rows(shape: Shape) -> list[list]:
    pc = shape.pieces
    return [[k, L, a, b] for k, L, a, b in zip(shape.kinds, pc.lengths, pc.start, pc.end)]


def _build(rows: list[list], continuous: bool) -> Shape:
    kinds, lengths, start, end = zip(*rows)
    return Shape.build(kinds, lengths, start, end, continuous=continuous)


def insert_pieces(shape: Shape, at_s: Array, length: Array, *, min_length_m: float,
                  continuous: bool) -> Shape:
    """Split the pieces at positions `at_s` (m) with a new piece of `length` (m) each.

    The new piece is an arc (`CONST`) horizontally; vertically (`continuous`) a vertical
    curve (`RAMP`), and a vertical curve is cut in two. Values start continuous (the
    profile is unchanged but for the new piece's flat middle).
    """
    rows = _rows(shape)
    pc = shape.pieces
    for x, ell in sorted(zip(at_s, length), reverse=True):
        j = int(pc.piece_of(np.array([x]))[0])
        kind, L, a, b = rows[j]
        ell = min(ell, L / 3.0)
        if ell < min_length_m:
            continue
        value = float(pc.value(np.array([x]), np.array([j]))[0])
        left = float(np.clip(x - pc.knots[j] - 0.5 * ell, min_length_m, L - ell - min_length_m))
        right = L - ell - left
        if continuous and kind == RAMP:
            new = [[RAMP, left + 0.5 * ell, a, value], [RAMP, right + 0.5 * ell, value, b]]
        else:
            new = [[kind, left, a, value], [RAMP if continuous else CONST, ell, value, value],
                   [kind, right, value, b]]
        rows[j:j + 1] = new
    return _build(rows, continuous)


def remove_piece(shape: Shape, j: int, *, continuous: bool) -> Shape:
    """The shape without piece j, its length shared by its neighbours."""
    rows = [list(r) for r in _rows(shape)]
    L = rows[j][1]
    neighbours = [k for k in (j - 1, j + 1) if 0 <= k < len(rows)]
    for k in neighbours:
        rows[k][1] += L / len(neighbours)
    del rows[j]
    return _build(rows, continuous)


def _runs(bad: npt.NDArray[np.intp], residual: Array) -> list[int]:
    """Index of the worst point of each run of violating points."""
    if not len(bad):
        return []
    cuts = np.flatnonzero(np.diff(bad) > RUN_GAP_POINTS) + 1
    return [int(run[np.argmax(np.abs(residual[run]))]) for run in np.split(bad, cuts)]


def refine(fit: FitFn, shape: Shape, tol_m: float, *, min_length_m: float, continuous: bool,
           warm: Any = None, progress: Callable[[int, int], None] | None = None):
    """Fit, then add pieces where points are outside `tol_m` until none is, or
    `MAX_REFINE_ROUNDS` pass, or `STALL_ROUNDS` rounds in a row did not lower the largest
    deviation (points no piece can reach: a height glitch). Returns the fit result with
    the smallest largest deviation."""
    result = fit(shape, warm)
    best, stalled = result, 0
    for round_ in range(MAX_REFINE_ROUNDS):
        r = result.residual_m
        worst = _runs(np.flatnonzero(np.abs(r) > tol_m), r)
        log.debug("refine round %d: %d pieces, max |r| %.3f m, %d runs outside", round_,
                  len(result.shape.kinds), _worst(result), len(worst))
        if progress is not None:
            progress(round_ + 1, MAX_REFINE_ROUNDS)
        if not worst or stalled >= STALL_ROUNDS:
            break
        s = result.s
        gap = np.diff(s)
        around = np.maximum(np.append(gap, 0.0) + np.insert(gap, 0, 0.0), min_length_m)
        shape = insert_pieces(result.shape, s[worst], around[worst],
                              min_length_m=min_length_m, continuous=continuous)
        result = fit(shape, result)
        if _worst(result) < (1.0 - STALL_FRACTION) * _worst(best):
            best, stalled = result, 0
        else:
            stalled += 1
    return result if _worst(result) <= _worst(best) else best


def _worst(result) -> float:
    return float(np.abs(result.residual_m).max(initial=0.0))


def _within(result, tol_m: float) -> bool:
    return _worst(result) <= tol_m


def _try_batches(fit: FitFn, result, tol_m: float, candidates: list[int],
                 apply: Callable[[Shape, list[int]], Shape], max_fits: int,
                 failed: list[float]) -> tuple[Any, int]:
    """Apply changes (by piece index, in order of preference) in batches of pieces at
    least three apart; return the first refit within `tol_m` (or the given result) and
    the number of fits made. A single change that fails adds its piece's middle (m) to
    `failed`; pieces holding such a point are not tried again."""
    knots = result.shape.pieces.knots
    held = np.asarray(failed)
    open_ = [j for j in candidates
             if not np.any((held >= knots[j]) & (held <= knots[j + 1]))]
    fits = 0
    batch_size = max(1, len(open_) // 2)
    while fits < max_fits and open_:
        batch: list[int] = []
        for j in open_:
            if all(abs(j - b) > 2 for b in batch):
                batch.append(j)
            if len(batch) >= batch_size:
                break
        trial = fit(apply(result.shape, batch), result)
        fits += 1
        log.debug("batch of %d changes: %d pieces, max |r| %.3f m", len(batch),
                  len(trial.shape.kinds), _worst(trial))
        if _within(trial, tol_m):
            return trial, fits
        if len(batch) == 1:
            failed.append(0.5 * (knots[batch[0]] + knots[batch[0] + 1]))
            open_.remove(batch[0])
        batch_size = max(1, len(batch) // 2)
    return result, fits


def simplify(fit: FitFn, result, tol_m: float, *, max_fits: int):
    """Tie transitions to their neighbours' curvatures (`FREE` → `RAMP`) and turn arcs of
    negligible curvature into straights, in batches kept when within `tol_m` (or, for a
    result already outside it, not farther outside)."""

    def changes(shape: Shape):
        pc = shape.pieces
        flat = np.abs(pc.start) * pc.lengths ** 2 / 8.0 < FLAT_FRACTION * tol_m
        candidates = [j for j, k in enumerate(shape.kinds)
                      if k == FREE or (k == CONST and flat[j])]

        def apply(shape: Shape, batch: list[int]) -> Shape:
            rows = _rows(shape)
            for j in batch:
                rows[j][0] = RAMP if rows[j][0] == FREE else ZERO
                if rows[j][0] == ZERO:
                    rows[j][2] = rows[j][3] = 0.0
            return _build(rows, False)

        return candidates, apply

    return _refine(fit, result, tol_m, changes, max_fits=max_fits)


def _refine(fit: FitFn, result, tol_m: float,
            changes: Callable[[Shape], tuple[list[int], Callable[[Shape, list[int]], Shape]]],
            *, max_fits: int):
    """Apply rounds of `changes` (candidate pieces and how to change them, from the current
    shape) through `_try_batches` until a round changes nothing, no candidate is left or
    `max_fits` refits are spent; the tolerance is at least the result's own worst
    deviation (a result already outside it may not get farther outside)."""
    tol_m = max(tol_m, _worst(result))
    fits = 0
    failed: list[float] = []
    while fits < max_fits:
        candidates, apply = changes(result.shape)
        if not candidates:
            break
        new, n = _try_batches(fit, result, tol_m, candidates, apply, max_fits - fits, failed)
        fits += n
        if new is result:
            break
        result = new
    return result


def _removal_cost(shape: Shape) -> Array:
    """Estimated lateral effect (m) of removing each piece: its length² / 8 times the
    difference of its mean value from its neighbours' adjacent values."""
    pc = shape.pieces
    mean = 0.5 * (pc.start + pc.end)
    before = np.concatenate([[pc.start[0]], pc.end[:-1]])
    after = np.concatenate([pc.start[1:], [pc.end[-1]]])
    return pc.lengths ** 2 / 8.0 * np.abs(mean - 0.5 * (before + after))


def prune(fit: FitFn, result, tol_m: float, *, continuous: bool, max_fits: int):
    """Remove pieces (cheapest first) while the refit stays within `tol_m` (or, for a
    result already outside it, not farther outside)."""

    def changes(shape: Shape):
        if len(shape.kinds) <= 1:
            return [], None

        def apply(shape: Shape, batch: list[int]) -> Shape:
            for j in sorted(batch, reverse=True):
                shape = remove_piece(shape, j, continuous=continuous)
            return shape

        return [int(j) for j in np.argsort(_removal_cost(shape))], apply

    return _refine(fit, result, tol_m, changes, max_fits=max_fits)
