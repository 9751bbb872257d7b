"""The track sampled on a fine grid around the vehicle, for per-step filter parameters.

The filters linearize the track about a reference distance ``s_ref`` and expand it in
``δ = s − s_ref`` inside their models (`strapdown.reduced`: the tangent to second order
through ``d²u/ds²``, the curvature vector to first order). ``s_ref`` therefore need not be
the predicted distance itself, only near it: taking the nearest node of a grid with
spacing ``h`` leaves ``|δ| ≤ h/2``, and the first neglected term of the tangent,
``|d³u/ds³| δ³/6`` with ``|d³u/ds³| ≲ 3κ|dκ/ds| + κ³ ≈ 1e-7 m⁻³`` (a 600 m curve entered
by a 120 m transition), is ~3e-10 for ``h = 0.5 m``. One `Track.at` call then serves a
window of track instead of one call per filter chunk (the call's fixed cost dominates for
short queries).

A curvature step (an arc or straight joined to another without a transition: turnouts'
reverse curves, a circle entered straight; `trackmodel.sections.JointSteps.
curvature_steps_m`) has no expansion across it: a sample on one side whose nearest node
lies on the other took that side's curvature, an error of ``v² Δκ`` in the
pseudo-observation (1.6 m/s² at 20 m/s on a 500-m reverse curve). The grid therefore
also has a node `trackmodel.sections.JOINT_SIDE_M` before and after each such step, so
the nearest node is on the sample's side. Measured on the synthetic switch network
(`benchmarks/bench_network_switches.py`, seeds 3 and 7): the network run's
pseudo-observation alarms (`railnav.navigation.network_status`) 13 → 1 and 11 → 1. The
shipped ``paper2017`` and ``curvy`` tracks have no horizontal curvature step, so their
runs are unchanged. Vertical-curvature steps (a grade entering a parabolic
vertical curve: ``curvy`` has 12, 7.5e-5 1/m) are not treated so (left).
"""
from __future__ import annotations

from dataclasses import fields
from functools import cached_property, lru_cache

import numpy as np
import numpy.typing as npt

from strapdown.reduced import track_parameters
from trackmodel.sections import JOINT_SIDE_M, joint_steps

__all__ = ["TrackParameterGrid", "parameters_together", "GRID_STEP_M", "GRID_WINDOW_M"]

Array = npt.NDArray[np.float64]

#: Grid spacing, m.
GRID_STEP_M = 0.5
#: Length of track sampled per window, m (re-sampled when the vehicle leaves it).
GRID_WINDOW_M = 2000.0


@lru_cache(maxsize=8)
def _field_names(cls) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


class TrackParameterGrid:
    """Track points and reduced-model parameters on a moving window of grid nodes.

    Parameters
    ----------
    track : trackmodel.Track
    step_m : float
        Node spacing, m.
    window_m : float
        Window length, m; it extends 3/4 ahead of and 1/4 behind the query that opened it.
    """

    def __init__(self, track, *, step_m: float = GRID_STEP_M,
                 window_m: float = GRID_WINDOW_M) -> None:
        self.track, self.step_m, self.window_m = track, float(step_m), float(window_m)
        self._lo = self._hi = np.nan
        self._s = self._params = self._points = None

    def _open(self, s_min: float, s_max: float) -> None:
        length = self.track.length_m
        span = max(self.window_m, s_max - s_min + 2.0 * self.step_m)
        start = max(s_min - 0.25 * span, 0.0)
        stop = min(max(start + span, s_max), length)
        k = np.arange(np.floor(start / self.step_m), np.ceil(stop / self.step_m) + 1.0)
        nodes = np.minimum(k * self.step_m, length)                # the track end is a node
        steps = self.curvature_steps
        steps = steps[(steps > start) & (steps < stop)]
        if steps.size:              # a node each side of a curvature step (module docstring)
            nodes = np.concatenate([nodes, steps - JOINT_SIDE_M, steps + JOINT_SIDE_M])
        nodes = np.unique(nodes)
        self._points = self.track.at(nodes)
        #: The points' fields in their order (`point`'s arguments).
        self._columns = tuple(getattr(self._points, name)
                              for name in _field_names(type(self._points)))
        self._params = track_parameters(self._points, earth=self.track.earth)
        self._s = nodes
        self._lo, self._hi = nodes[0], nodes[-1]

    @cached_property
    def curvature_steps(self) -> Array:
        """``s`` of the track's horizontal curvature steps
        (`trackmodel.sections.JointSteps.curvature_steps_m`), m."""
        return joint_steps(self.track.table).curvature_steps_m

    def nearest(self, s: Array) -> npt.NDArray[np.intp]:
        """Indices of the grid nodes nearest to distances `s` (m, inside the track)."""
        s = np.asarray(s, dtype=float)
        # s.min(), s.max(): the same reductions, without the methods' Python wrappers
        s_min, s_max = np.minimum.reduce(s), np.maximum.reduce(s)
        if not (self._lo <= s_min and s_max <= self._hi):
            self._open(float(s_min), float(s_max))
        j = np.minimum(np.maximum(self._s.searchsorted(s), 1), self._s.size - 1)
        return np.where(s - self._s[j - 1] <= self._s[j] - s, j - 1, j)

    def parameters(self, s: Array) -> tuple[Array, npt.NDArray[np.intp]]:
        """Reduced-model parameter rows (`strapdown.reduced.TRACK_PARAMETER_NAMES`) at the
        nodes nearest to `s`, shape (M, 16), and those node indices."""
        idx = self.nearest(s)
        return self._params[idx], idx

    def point(self, index: int):
        """The scalar `trackmodel.TrackPoint` of node `index` (of the current window)."""
        return type(self._points)(*[column[index] for column in self._columns])


def parameters_together(grids, s: Array) -> list[tuple[Array, npt.NDArray[np.intp]]]:
    """`TrackParameterGrid.parameters` of each grid (distinct objects) at its row of `s`
    (K, M), m: each grid's window opened as its own call opens it, then the nearest
    nodes of all rows found by one search in the windows' nodes side by side (a node
    ``s`` of grid k keyed ``k + i·s``: complex numbers sort by real part, then
    imaginary, so a row's search stays in its own window and makes the same float
    comparisons as there), each row's parameters gathered from its own grid. Returns
    each grid's ``(rows, node indices)``."""
    lo, hi = np.minimum.reduce(s, axis=1), np.maximum.reduce(s, axis=1)
    for grid, a, b in zip(grids, lo, hi):
        if not (grid._lo <= a and b <= grid._hi):
            grid._open(float(a), float(b))
    windows = _windows(grids)
    if windows is None:                                   # a window of one node
        return [grid.parameters(row) for grid, row in zip(grids, s)]
    nodes, keys, first, size = windows
    K, M = s.shape
    query = np.empty(s.shape, dtype=np.complex128)
    query.real, query.imag = np.arange(K, dtype=float)[:, None], s
    j = np.minimum(np.maximum(keys.searchsorted(query) - first[:, None], 1),
                   size[:, None] - 1)
    at = j + first[:, None]
    idx = np.where(s - nodes[at - 1] <= nodes[at] - s, j - 1, j)
    return [(grid._params[i], i) for grid, i in zip(grids, idx)]


#: The latest windows side by side: ``(their node arrays, (nodes, keys, first, size))``;
#: one tuple, replaced whole (a thread reads a pair that belongs together).
_LATEST: tuple = ((), None)


def _windows(grids):
    """The grids' current windows side by side for `parameters_together` (kept while
    they are the same arrays); None when a window has fewer than two nodes."""
    global _LATEST
    arrays = tuple(grid._s for grid in grids)
    held, found = _LATEST
    if len(held) != len(arrays) or any(a is not b for a, b in zip(held, arrays)):
        size = np.array([a.size for a in arrays])
        if size.min() < 2:
            return None
        nodes = np.concatenate(arrays)
        keys = np.empty(nodes.size, dtype=np.complex128)
        keys.real, keys.imag = np.repeat(np.arange(len(arrays), dtype=float), size), nodes
        found = (nodes, keys, np.cumsum(size) - size, size)
        _LATEST = (arrays, found)
    return found
