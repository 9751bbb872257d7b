r"""The tracks of a network's oriented elements on one table of nodes, for the stacked
fix-only cycle (`railnav.navigation.stacked_fixes`, module docstring: a point is its
nearest node expanded to second order in ``δ = s − s_node``).
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from trackmodel.earth import C_n_e
from trackmodel.network_points import expanded_points

__all__ = ["FixGrid", "GRID_STEP_M"]

Array = npt.NDArray[np.float64]

#: Node spacing of the track tables, m.
GRID_STEP_M = 0.5
#: Sets of hypotheses' elements whose table positions (`FixGrid`) or composed noise
#: (`railnav.navigation.stacked_fixes`) are kept (then forgotten together).
MAX_KEY_SETS = 256


class FixGrid:
    """Every oriented element's track on nodes every `GRID_STEP_M`, in one table."""

    def __init__(self, tracks) -> None:
        self.tracks = tracks
        self._offset: dict[tuple[str, int], int] = {}
        self._length: dict[tuple[str, int], float] = {}
        names = ("r", "C", "u", "du", "A", "E", "dA", "dE", "h")
        self._parts: dict[str, list] = {n: [] for n in names}
        self._table: dict[str, Array] | None = None
        self._size = 0
        self._keyed: dict[tuple, tuple[Array, Array]] = {}   # keys -> lengths, offsets

    def _add(self, key: tuple[str, int]) -> None:
        track = self.tracks.track(*key)
        n = int(math.ceil(track.length_m / GRID_STEP_M)) + 1
        p = track.at(np.minimum(np.arange(n) * GRID_STEP_M, track.length_m))
        values = {"r": np.asarray(p.r_e), "C": C_n_e(p.lat, p.lon), "u": np.asarray(p.u_n),
                  "du": np.asarray(p.du_ds_n), "A": np.asarray(p.azimuth),
                  "E": np.asarray(p.elevation), "dA": np.asarray(p.curvature_1pm),
                  "dE": np.broadcast_to(p.elevation_rate, (n,)), "h": np.asarray(p.h)}
        for name, value in values.items():
            self._parts[name].append(np.asarray(value, dtype=float))
        self._offset[key], self._length[key] = self._size, float(track.length_m)
        self._size += n
        self._table = None

    #: Columns of each quantity in the one table of nodes (`_columns`).
    _WIDTH = {"r": 3, "C": 9, "u": 3, "du": 3, "A": 1, "E": 1, "dA": 1, "dE": 1, "h": 1}

    def _nodes(self, keys, s: Array) -> tuple[Array, Array]:
        """The table rows of the nodes nearest ``s`` on `keys` (K, 22) and ``δ = s −
        s_node`` (beyond an element's end, from its end node)."""
        for key in keys:
            if key not in self._offset:
                self._add(key)
        if self._table is None:        # one table: one gather per call, not nine
            self._table = np.column_stack([np.concatenate(v).reshape(self._size, -1)
                                           for v in self._parts.values()])
        cached = self._keyed.get(tuple(keys))
        if cached is None:
            cached = (np.array([self._length[k] for k in keys]),
                      np.array([self._offset[k] for k in keys]))
            if len(self._keyed) >= MAX_KEY_SETS:
                self._keyed.clear()
            self._keyed[tuple(keys)] = cached
        length, offset = cached
        node = np.rint(np.minimum(np.maximum(s, 0.0), length) / GRID_STEP_M)  # np.clip
        d = s - np.minimum(node * GRID_STEP_M, length)     # beyond an end: extrapolated
        return self._table[offset + node.astype(int)], d

    @staticmethod
    def _columns(row: Array) -> dict[str, Array]:
        """The quantities of gathered table rows, by name (contiguous copies: the same
        products as from separate tables)."""
        out, start = {}, 0
        for name, width in FixGrid._WIDTH.items():
            part = row[:, start:start + width]
            if name in _REDUCED:
                out[name] = np.ascontiguousarray(part.reshape(-1, 3, 3) if name == "C"
                                                 else part)
            else:                           # elementwise use only: any layout, same bits
                out[name] = part if width > 1 else part[:, 0]
            start += width
        return out

    def points(self, keys, s: Array) -> dict[str, Array]:
        """The track quantities at ``s`` of hypotheses on oriented elements `keys`
        (module docstring; beyond an element's end, expanded from its end node as the
        fix rows expand the track from the clamped ``s``)."""
        row, d = self._nodes(keys, s)
        tab = self._columns(row)
        r, u_at = _expanded(tab, d)
        u = tab["u"]
        return {"r": r, "C": tab["C"], "u": u_at, "du": tab["du"],
                "A": tab["A"] + tab["dA"] * d, "E": tab["E"] + tab["dE"] * d,
                "h": tab["h"] + u[:, 2] * d}

    def track_points(self, keys, s: Array) -> tuple[Array, Array]:
        """ECEF position and unit tangent at ``s`` (those of `points`: ``r`` and ``C u``),
        shapes (K, 3)."""
        row, d = self._nodes(keys, s)
        tab = self._columns(row)
        r, u_at = _expanded(tab, d)
        return r, np.einsum("kij,kj->ki", tab["C"], u_at)


def _expanded(tab: dict[str, Array], d: Array) -> tuple[Array, Array]:
    """ECEF position and ENU tangent ``δ = d`` past the nodes of `tab` (`FixGrid._columns`;
    `trackmodel.network_points.expanded_points`)."""
    return expanded_points(tab["r"], tab["C"], tab["u"], tab["du"], d)


#: The table's quantities that enter reductions (einsum, matrix products): taken as
#: contiguous copies, as from separate tables (a reduction's summation may depend on the
#: layout); the others enter elementwise arithmetic only.
_REDUCED = ("C", "u", "du")
