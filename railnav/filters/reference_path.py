"""The reference path of a constrained filter's chunk: the along-track distance predicted.

From the filter's state at the chunk start, the along-track distance of each sample is
predicted with the along-track specific force, ``a ≈ f_x − b_ax − g sin θ`` (cm-accurate
over a second; ``s`` by the trapezoidal rule): the track quantities of the chunk are taken there
(`railnav.filters.constrained.ConstrainedFilter.inputs`, `railnav.filters.track_grid`).
|g| is looked up once per kilometre of track.

`ReferencePath` is that part of `railnav.filters.constrained.ConstrainedFilter`: it reads
the filter's ``track``, the state indices ``_i`` (``pitch``, ``s``, ``v``), ``_b_ax``
(None without bias states) and its gravity cache ``_gravity`` (a dict).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from strapdown.gravity import g_n

__all__ = ["ReferencePath", "paths_together"]

Array = npt.NDArray[np.float64]

#: Gravity for the along-track prediction is looked up once per this much track, m (it
#: changes by ~3e-6 m/s² per km of height or latitude: far below what the prediction needs).
_GRAVITY_CACHE_M = 1000.0


def _shifted(a: Array, first: float) -> Array:
    """``[first, a[0], ..., a[-2]]`` (``np.concatenate([[first], a[:-1]])``, without the
    conversion of the list)."""
    out = np.empty(a.size)
    if a.size:
        out[0] = first
        out[1:] = a[:-1]
    return out


class ReferencePath:
    """The along-track prediction of a chunk's samples (module docstring)."""

    def predict_s(self, t: Array, accel: Array, x_prev: Array, t_prev: float) -> Array:
        """Along-track distance at ``t`` predicted from the state at ``t_prev`` and the
        samples' along-track acceleration `accel` (m/s², `_along_accel`), m."""
        i = self._i
        dt = t - _shifted(t, t_prev)                  # np.diff of [t_prev, *t]
        # np.cumsum's accumulation, without its wrapper
        v = x_prev[i["v"]] + np.add.accumulate(accel * dt)
        v_mid = 0.5 * (_shifted(v, x_prev[i["v"]]) + v)
        s = x_prev[i["s"]] + np.add.accumulate(v_mid * dt)
        return np.minimum(np.maximum(s, 0.0), self.track.length_m)   # np.clip, faster

    def _along_accel(self, u: Array, x_prev: Array) -> Array:
        """Along-track acceleration of samples `u` from the state `x_prev`,
        ``f_x − b_ax − g sin θ`` (m/s²)."""
        gravity = self._gravity_near(x_prev[self._i["s"]])
        f_x = u[:, 0] - (x_prev[self._b_ax] if self._b_ax is not None else 0.0)
        return f_x - gravity * np.sin(x_prev[self._i["pitch"]])

    def _gravity_near(self, s: float) -> float:
        """|g| (m/s²) at the track point nearest `s`, cached per kilometre of track."""
        key = int(s // _GRAVITY_CACHE_M)
        if key not in self._gravity:
            point = self.track.at(min(max(s, 0.0), self.track.length_m))
            self._gravity[key] = float(np.linalg.norm(g_n(point.lat, point.h,
                                                          earth=self.track.earth)))
        return self._gravity[key]


def paths_together(filters, t: Array, u: Array, X: Array, t_prev: float
                   ) -> tuple[Array, Array]:
    """`ReferencePath._along_accel` and `ReferencePath.predict_s` of several filters of
    one layout (a bank's hypotheses, each on its own track) over the same samples, each
    from its own prior ``X[k]`` (shape (K, n)): the accelerations and the predicted
    distances, shapes (K, M), row k the numbers of filter k's own calls (the same
    elementwise operations, stacked; the sums accumulated along each row)."""
    f0 = filters[0]
    i_s, i_v = f0._i["s"], f0._i["v"]
    gravity = np.array([f._gravity_near(x[i_s]) for f, x in zip(filters, X)])
    f_x = u[:, 0][None, :] - (X[:, f0._b_ax][:, None] if f0._b_ax is not None else 0.0)
    accel = f_x - (gravity * np.sin(X[:, f0._i["pitch"]]))[:, None]
    dt = t - _shifted(t, t_prev)
    v = X[:, i_v][:, None] + np.add.accumulate(accel * dt, axis=1)
    before = np.empty(v.shape)                       # `_shifted` of each row
    if t.size:
        before[:, 0] = X[:, i_v]
        before[:, 1:] = v[:, :-1]
    v_mid = 0.5 * (before + v)
    s = X[:, i_s][:, None] + np.add.accumulate(v_mid * dt, axis=1)
    lengths = np.array([f.track.length_m for f in filters])
    return accel, np.minimum(np.maximum(s, 0.0), lengths[:, None])
