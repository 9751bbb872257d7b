"""Typed piecewise-linear profiles along ``s``: the shape of a fitted section table.

A profile ``f(s)`` on knots ``τ_0 = 0 < … < τ_m = L`` (m) is linear on each piece ``j``,
from a start value ``a_j`` to an end value ``b_j``. For the horizontal fit ``f`` is the
curvature ``κ = dA/ds`` (1/m), for the vertical fit the elevation ``ϑ`` (rad). A piece has a
**kind**:

=======  ==========================  =========================================================
kind     horizontal (f = κ)          vertical (f = ϑ)
=======  ==========================  =========================================================
`ZERO`   straight (κ = 0)            level (ϑ = 0)
`CONST`  circular arc (κ = c)        constant grade (ϑ = c)
`RAMP`   clothoid transition         vertical curve
`FREE`   clothoid (may jump at ends)  (not used: ϑ must not jump)
=======  ==========================  =========================================================

A `RAMP` runs from the end value of the piece before it to the start value of the piece
after it (so it joins them without a jump). Where a ramp meets another ramp, or is the
first or last piece, its value there is a free parameter. A `FREE` piece is linear with
its own start and end values. A `Layout` (the kinds) maps the
free values (one per `CONST`, one per such ramp joint or end) onto the pieces; the
parameters of a profile are the piece lengths and these values.

`CellGrid` cuts the pieces into integration cells (Simpson's rule per cell, cubic Hermite
interpolation between cell ends): a cell never straddles a knot, so each integrand is
smooth within its cell even where ``f`` jumps.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

__all__ = ["ZERO", "CONST", "RAMP", "FREE", "KIND_LETTERS", "Layout", "Pieces", "Shape",
           "CellGrid"]

Array = npt.NDArray[np.float64]
IArray = npt.NDArray[np.intp]

ZERO, CONST, RAMP, FREE = 0, 1, 2, 3
#: One letter per kind, for logs and tests.
KIND_LETTERS = "SACF"


@dataclass(frozen=True)
class Layout:
    """The kinds of the pieces and where their start and end values come from.

    Parameters
    ----------
    kinds : tuple of int
        `ZERO`, `CONST` or `RAMP` for each piece, in order along s.

    Attributes
    ----------
    start_index, end_index : ndarray of int, shape (m,)
        Index of each piece's start/end value in ``[0, v_1, …, v_n]`` (0: the value zero).
    n_values : int
        Number of free values n.
    """

    kinds: tuple[int, ...]

    @cached_property
    def _maps(self) -> tuple[IArray, IArray, int]:
        m = len(self.kinds)
        start, end = np.zeros(m, dtype=np.intp), np.zeros(m, dtype=np.intp)
        n = 0
        for j, kind in enumerate(self.kinds):
            if kind == CONST:
                n += 1
                start[j] = end[j] = n
            elif kind == FREE:
                start[j], end[j] = n + 1, n + 2
                n += 2
        for j, kind in enumerate(self.kinds):
            if kind != RAMP:
                continue
            if j > 0:
                start[j] = end[j - 1]            # a preceding ramp set it as a joint value
            else:
                n += 1
                start[j] = n
            if j < m - 1 and self.kinds[j + 1] != RAMP:
                end[j] = start[j + 1]
            else:
                n += 1
                end[j] = n
        return start, end, n

    @property
    def start_index(self) -> IArray:
        return self._maps[0]

    @property
    def end_index(self) -> IArray:
        return self._maps[1]

    @property
    def n_values(self) -> int:
        return self._maps[2]

    def __len__(self) -> int:
        return len(self.kinds)

    def __str__(self) -> str:
        return "".join(KIND_LETTERS[k] for k in self.kinds)

    def pieces(self, lengths: Array, values: Array) -> "Pieces":
        """The profile with these piece lengths (m) and free values."""
        v = np.concatenate([[0.0], values])
        knots = np.concatenate([[0.0], np.cumsum(lengths)])
        return Pieces(knots, v[self.start_index], v[self.end_index])

    def values_of(self, pieces: "Pieces") -> Array:
        """Free values read off a profile of this layout (the mean where several apply)."""
        total, count = np.zeros(self.n_values + 1), np.zeros(self.n_values + 1)
        np.add.at(total, self.start_index, pieces.start)
        np.add.at(total, self.end_index, pieces.end)
        np.add.at(count, self.start_index, 1.0)
        np.add.at(count, self.end_index, 1.0)
        return (total / np.maximum(count, 1.0))[1:]

    @cached_property
    def _incidence(self) -> tuple[Array, Array]:
        """One-hot maps of the pieces' start and end values onto the free values, (m, n)."""
        m, n = len(self.kinds), self.n_values
        S, E = np.zeros((m, n + 1)), np.zeros((m, n + 1))
        S[np.arange(m), self.start_index] = 1.0
        E[np.arange(m), self.end_index] = 1.0
        return S[:, 1:], E[:, 1:]

    def value_jacobian(self, d_start: Array, d_end: Array) -> Array:
        """Chain rule: derivatives with respect to the piece start/end values, shape
        (..., m) each, to derivatives with respect to the free values, shape (..., n)."""
        S, E = self._incidence
        return d_start @ S + d_end @ E


@dataclass(frozen=True)
class Pieces:
    """A piecewise-linear profile.

    Attributes
    ----------
    knots : ndarray, shape (m + 1,)
        Piece ends along s, m, increasing, ``knots[0] == 0``.
    start, end : ndarray, shape (m,)
        Value at the start and end of each piece (1/m for a curvature, rad for an elevation).
    """

    knots: Array
    start: Array
    end: Array

    @property
    def length(self) -> float:
        return float(self.knots[-1])

    @property
    def lengths(self) -> Array:
        return np.diff(self.knots)

    def piece_of(self, s: Array) -> IArray:
        """Index of the piece holding each s (a knot belongs to the piece it starts)."""
        return np.clip(np.searchsorted(self.knots, s, side="right") - 1, 0, len(self.start) - 1)

    @property
    def slope(self) -> Array:
        """``(b_j − a_j) / L_j`` per piece."""
        return (self.end - self.start) / self.lengths

    def value(self, s: Array, j: IArray | None = None) -> Array:
        """``f(s)``, linear extrapolation of the end pieces beyond ``[0, L]``."""
        j = self.piece_of(s) if j is None else j
        return self.start[j] + self.slope[j] * (s - self.knots[j])

    @cached_property
    def _cumulative(self) -> Array:
        return np.concatenate([[0.0], np.cumsum(0.5 * (self.start + self.end) * self.lengths)])

    def integral_jacobian(self, s: Array) -> tuple[Array, Array, Array]:
        """``∂/∂L_j``, ``∂/∂a_j`` and ``∂/∂b_j`` of ``∫₀ˢ f`` at fixed s, shape (N, m) each.

        Inside piece j (``t = s − τ_j``): ``−(b_j − a_j) t²/2L_j²``, ``t − t²/2L_j`` and
        ``t²/2L_j``; after it: ``(a_j + b_j)/2 − f(s)`` (the later pieces move along),
        ``L_j/2`` and ``L_j/2``.
        """
        L = self.lengths
        t = np.clip(s[:, None] - self.knots[None, :-1], 0.0, L[None, :])
        q = t * t / (2.0 * L)
        after = s[:, None] >= self.knots[None, 1:]
        dL = np.where(after, 0.5 * (self.start + self.end) - self.value(s)[:, None],
                      -self.slope * q)
        return dL, t - q, q

    def integral(self, s: Array, j: IArray | None = None) -> Array:
        """``∫₀ˢ f``."""
        j = self.piece_of(s) if j is None else j
        t = s - self.knots[j]
        return self._cumulative[j] + self.start[j] * t + 0.5 * self.slope[j] * t * t


@dataclass(frozen=True)
class Shape:
    """A profile in fitting form: its layout, piece lengths (m) and free values."""

    layout: Layout
    lengths: Array
    values: Array

    @property
    def pieces(self) -> Pieces:
        return self.layout.pieces(self.lengths, self.values)

    @property
    def kinds(self) -> tuple[int, ...]:
        return self.layout.kinds

    @classmethod
    def build(cls, kinds, lengths, start, end, *, continuous: bool = False) -> "Shape":
        """Shape from per-piece kinds, lengths and start/end values, tidied:

        * consecutive straights merged (and, if `continuous`, any two neighbouring pieces
          that are not ramps: a constant grade next to another would be a kink; the
          merged value is their length-weighted mean);
        * a ramp tied to zero at both ends (between two straights) split in two ramps
          meeting at its mean value.
        """
        out: list[list] = []
        for kind, L, a, b in zip(kinds, lengths, start, end):
            if out and out[-1][0] != RAMP and kind != RAMP and (
                    continuous or (kind == ZERO and out[-1][0] == ZERO)):
                k0, L0, a0, _ = out[-1]
                c = (a0 * L0 + a * L) / (L0 + L)
                out[-1] = [k0 if k0 == kind else CONST, L0 + L, c, c]
            else:
                out.append([kind, float(L), float(a), float(b)])
        kinds = [o[0] for o in out]
        rows: list[list] = []
        for j, (kind, L, a, b) in enumerate(out):
            flat_before = j > 0 and kinds[j - 1] == ZERO
            flat_after = j < len(out) - 1 and kinds[j + 1] == ZERO
            if kind == RAMP and flat_before and flat_after:
                mid = 0.5 * (a + b) if a or b else 0.0
                rows += [[RAMP, 0.5 * L, 0.0, mid], [RAMP, 0.5 * L, mid, 0.0]]
            else:
                rows.append([kind, L, a, b])
        layout = Layout(tuple(int(r[0]) for r in rows))
        L, a, b = (np.array([r[i] for r in rows], dtype=float) for i in (1, 2, 3))
        knots = np.concatenate([[0.0], np.cumsum(L)])
        return cls(layout, L, layout.values_of(Pieces(knots, a, b)))


@dataclass(frozen=True)
class CellGrid:
    """Integration cells over ``[0, L]``, never straddling a knot.

    Attributes
    ----------
    left : ndarray, shape (G,)
        Left end of each cell, m.
    width : ndarray, shape (G,)
        Cell widths, m.
    piece : ndarray of int, shape (G,)
        The piece each cell lies in.
    """

    left: Array
    width: Array
    piece: IArray

    @classmethod
    def build(cls, pieces: Pieces, step: Array) -> "CellGrid":
        """Cells of at most ``step[j]`` metres in piece j."""
        L = pieces.lengths
        n = np.maximum(1, np.ceil(L / step).astype(np.intp))
        piece = np.repeat(np.arange(len(L)), n)
        first = np.concatenate([[0], np.cumsum(n)[:-1]])
        k = np.arange(piece.size) - first[piece]
        width = (L / n)[piece]
        return cls(pieces.knots[piece] + k * width, width, piece)

    @cached_property
    def nodes(self) -> Array:
        """Cell ends, shape (G + 1,), m."""
        return np.append(self.left, self.left[-1] + self.width[-1])

    def points(self) -> tuple[Array, Array, Array]:
        """Left ends, midpoints and right ends of the cells, m."""
        return self.left, self.left + 0.5 * self.width, self.left + self.width

    def cumulative(self, f_left: Array, f_mid: Array, f_right: Array, *,
                   per_piece: bool = False) -> tuple[Array, Array]:
        """Running integral (Simpson's rule per cell) of an integrand sampled at `points`
        (shape (G, ...) each), at the left and at the right end of every cell; from s = 0,
        or from the start of each cell's piece if `per_piece`."""
        cells = (self.width / 6.0).reshape((-1,) + (1,) * (f_left.ndim - 1)) * (
            f_left + 4.0 * f_mid + f_right)
        zero = np.zeros((1,) + cells.shape[1:], dtype=cells.dtype)
        total = np.concatenate([zero, np.cumsum(cells, axis=0)])
        base = total[self.first_cell[self.piece]] if per_piece else 0.0
        return total[:-1] - base, total[1:] - base

    @cached_property
    def first_cell(self) -> IArray:
        """Index of the first cell of each piece, shape (m,)."""
        return np.flatnonzero(np.diff(self.piece, prepend=-1) != 0)

    def cell_of(self, s: Array, piece: IArray | None = None) -> IArray:
        """Cell holding each s (within `piece` when given)."""
        i = np.searchsorted(self.left, s, side="right") - 1
        if piece is not None:
            last = np.append(self.first_cell[1:], self.left.size) - 1
            i = np.clip(i, self.first_cell[piece], last[piece])
        return np.clip(i, 0, self.left.size - 1)

    def hermite(self, F_left: Array, F_right: Array, f_left: Array, f_right: Array,
                s: Array, cell: IArray) -> Array:
        """``F(s)`` by cubic Hermite interpolation in each s's cell from the values (G, ...)
        and derivatives (G, ...) of F at the cells' left and right ends."""
        h = self.width[cell]
        x = (s - self.left[cell]) / h
        h, x = (a.reshape(a.shape + (1,) * (F_left.ndim - 1)) for a in (h, x))
        x2, x3 = x * x, x * x * x
        return ((2 * x3 - 3 * x2 + 1) * F_left[cell] + (x3 - 2 * x2 + x) * h * f_left[cell]
                + (-2 * x3 + 3 * x2) * F_right[cell] + (x3 - x2) * h * f_right[cell])
