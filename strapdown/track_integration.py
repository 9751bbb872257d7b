"""Free-running integration of the reduced model along a track.

The reduced model takes the track through the per-step parameter vector ``p``
(`strapdown.reduced.track_parameters`) linearized at a reference distance ``s_ref``. When
no filter supplies ``s_ref``, `integrate_on_track` follows the model's own ``s``: blocks of
``block_steps`` steps are integrated twice — first with ``s_ref`` extrapolated at constant
speed from the block start, then with ``s_ref`` = the first pass's ``s`` at every step
start — so the linearization point stays within rounding of the state (the model carries
the remaining offset exactly to first order, and its second-order error is
``|d²u/ds²| δ²/2`` with ``δ`` the (tiny) second-pass offset).

The track is any object with ``at(s) -> TrackPoint``, ``length_m`` and ``earth``
(`trackmodel.Track`); ``s_ref`` is clamped to ``[0, length_m]`` (beyond the ends the model
extrapolates the end tangent linearly).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from strapdown.reduced import ReducedModel, track_parameters
from strapdown.rk4 import integrate

__all__ = ["integrate_on_track"]

#: Steps per block of `integrate_on_track` (1 s at 100 Hz).
DEFAULT_BLOCK_STEPS = 100


def integrate_on_track(model: ReducedModel, track: Any, x0: npt.ArrayLike,
                       u_samples: npt.ArrayLike, dt: float, *,
                       block_steps: int = DEFAULT_BLOCK_STEPS,
                       progress: Callable[[int, int], None] | None = None) -> np.ndarray:
    """Integrate the reduced model over IMU samples, the track following the model's ``s``.

    Parameters
    ----------
    model : ReducedModel
        Built for ``track.earth``.
    track : trackmodel.Track
    x0 : array_like, shape (n_x,)
        Initial state (`model.layout`), ``s`` in m, ``v`` in m/s, angles in rad.
    u_samples : array_like, shape (N + 1, 6)
        Instantaneous IMU samples ``[f_b, ω_ib_b]`` (`strapdown.rk4` convention).
    dt : float
        Sample interval, s.
    block_steps : int
        Steps per block (see the module docstring).
    progress : callable, optional
        ``progress(done_steps, total_steps)``.

    Returns
    -------
    ndarray, shape (N + 1, n_x)
        States at the sample times.
    """
    u = np.asarray(u_samples, dtype=float)
    x = np.asarray(x0, dtype=float).reshape(-1)
    i_s, i_v = model.layout.index("s"), model.layout.index("v")
    n_steps = u.shape[0] - 1
    out = np.empty((n_steps + 1, x.size))
    out[0] = x
    clamp = lambda s: np.clip(s, 0.0, track.length_m)  # noqa: E731
    for start in range(0, n_steps, block_steps):
        stop = min(start + block_steps, n_steps)
        u_blk = u[start:stop + 1]
        s_ref = x[i_s] + x[i_v] * dt * np.arange(stop - start)
        for _ in range(2):
            p = track_parameters(track.at(clamp(s_ref)), earth=model.earth)
            states = integrate(model.f, x, u_blk, dt, p)
            s_ref = states[:-1, i_s]
        out[start + 1:stop + 1] = states[1:]
        x = states[-1]
        if progress is not None:
            progress(stop, n_steps)
    return out
