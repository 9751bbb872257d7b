r"""A bound on what the rows beside a curvature step, each at its own prior, tell about ``s``.

`railnav.filters.step_blend` regresses the blend of each sample near a horizontal
curvature step over the filter's prior *at that sample*. A sample wholly on one side of
the step ("not yet", "already past") says only which side the train is on: a truncation
of the prior. Taken at face value, each such row adds the Gaussianized truncation as
information, the next row truncates the narrowed prior again, and σ_s collapses where the
truth is not (stop 34: the ring restart, 9.95–9.99 s, σ_s 0.97 → 0.068 m with the truth
1 m off; `docs/consistency-ablations.md`).

**The bound** is `railnav.filters.one_sided`'s, applied per row and per *episode* of one
step: whatever the one-sided rows say, the posterior of ``s`` is the episode's prior
truncated at the step ``c``, so its variance is at least the smaller of the two
truncations' (`one_sided.floor_variance`, the side away from the mean). The episode
starts at the first row whose own prior has the step in its window
(`geometry_noise.across_a_step` of the chunk's prior, as `step_blend` picks them) and
takes that row's prior of ``(s, v)``; its budget of precision of ``s`` is ``1/floor −
1/σ_ep²`` of that prior propagated at constant speed to each row (at the row's mean),
less what the episode's earlier one-sided rows took. A one-sided row whose information
would leave less variance than ``1/(1/σ²_row + remaining budget)`` has its noise density
``S_c = D Q_c Dᵀ + r_c`` scaled by the smallest ``λ_R ≥ 1`` that meets it
(`one_sided.factor_for`, over the ``(s, v)`` block: `one_sided.rows_information`), and the
precision it then takes (the same 2×2 model) is added to the used budget.

**The first row that straddles is not bounded**: the episode's first row whose own prior
mean puts the step within its interval, ``|s − c| ≤ |v| dt / 2``. Its blend is not a side
but a fraction, which tells ``s`` to the ramp's precision (the switch network's stale-line
event, the reason for `step_blend`, is read by it); nor does it use the budget. The truth
straddles once, so the rows after it are bounded, straddling by the estimate or not: on the
ring of stop 34 (the estimate 5 m, 5σ, ahead) every row was dragged back to the step and
"straddled" by the estimate, while the truth, 5 m short, said "not yet" at each; with all
of them unbounded σ_s fell 0.72 → 0.089 m in three rows (the ring-restart tests failed).

The episode ends when a chunk has no row near a step (`StepBlend.record`), or a row's
nearest step is another one.

Limits: the straddle test is the estimate's, not the truth's: with the estimate several
σ off, the row the truth straddles is bounded and the one the estimate straddles is not.
A row's information is counted in the model (its ``(s, v)`` rows at its prior), not
measured from the filter.
The ``(s, v)`` block leaves the attitude out, which overstates a row's information (the
factor errs on the safe side). Units: m, s, m/s; densities (m/s²)²·s.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from railnav.filters.one_sided import (factor_for, floor_variance, posterior_s_variance,
                                       propagated, rows_information)

__all__ = ["OneSidedRows"]

Array = npt.NDArray[np.float64]


class OneSidedRows:
    """The one-sided rows' budget of one curvature step's episode (module docstring).

    Parameters
    ----------
    steps_m : ndarray, shape (K,)
        The track's horizontal curvature steps, m (`TrackParameterGrid.curvature_steps`).
    i_s, i_v : int
        Indices of ``s`` and ``v`` in the state.
    w_f : sequence of int
        Indices of the accelerometer's ``w_fy``, ``w_fz`` in the process noise.
    """

    def __init__(self, steps_m: Array, i_s: int, i_v: int, w_f) -> None:
        self.steps_m = np.asarray(steps_m, dtype=float)
        self._sv = [int(i_s), int(i_v)]
        self._w_f = [int(k) for k in w_f]
        #: The episode: its step, start time, prior ``(s, v)`` block, precision used.
        self._episode: dict | None = None
        #: Rows scaled so far (diagnostics).
        self.rows_scaled = 0

    def end(self) -> None:
        """End the episode (a chunk with no row near a step)."""
        self._episode = None

    def bound(self, x: Array, P: Array, params: Array, r_c: Array, q_c: Array, *,
              t_s: float, step_s: float) -> Array:
        """The row's geometry density, scaled where a one-sided row would tell ``s`` more
        than the episode's truncation leaves.

        Parameters
        ----------
        x, P : ndarray, shapes (n,), (n, n)
            The filter's prior at the row's sample.
        params : ndarray, shape (16,)
            The row's track parameters (its line at that prior).
        r_c : ndarray, shape (2,)
            The row's geometry density, (m/s²)²·s.
        q_c : ndarray, shape (n_w,)
            The process noise densities of the row's step.
        t_s, step_s : float
            The sample's time and its step to the next, s.

        Returns
        -------
        ndarray, shape (2,)
            `r_c` itself when not scaled, else ``λ_R (r_c + D Q_c Dᵀ) − D Q_c Dᵀ``.
        """
        mean, speed = float(x[self._sv[0]]), abs(float(x[self._sv[1]]))
        block = P[np.ix_(self._sv, self._sv)]
        if self.steps_m.size == 0 or not block[0, 0] > 0.0:
            return r_c
        c = float(self.steps_m[int(np.argmin(np.abs(self.steps_m - mean)))])
        ep = self._episode
        if ep is None or ep["step"] != c:
            ep = self._episode = {"step": c, "t0": float(t_s), "block": block, "used": 0.0,
                                  "straddled": False}
        if not ep["straddled"] and abs(mean - c) <= 0.5 * speed * step_s:
            ep["straddled"] = True                                  # a fraction, once
            return r_c
        accel = np.asarray(q_c, dtype=float)[self._w_f]
        density = np.asarray(r_c, dtype=float) + accel
        info = rows_information(np.array([t_s + step_s]), np.array([mean]), params[None, :],
                                speed, density[None, :], t_s)
        try:
            prior_info = np.linalg.inv(block)
        except np.linalg.LinAlgError:                               # v known exactly
            return r_c
        var_ep = propagated(ep["block"], float(t_s) - ep["t0"])[0, 0]
        allowed = 1.0 / floor_variance(mean_m=mean, sigma_m=math.sqrt(var_ep), onset_m=c) \
            - 1.0 / var_ep
        floor = 1.0 / (1.0 / block[0, 0] + max(allowed - ep["used"], 0.0))
        factor = factor_for(prior_info, info, floor)
        ep["used"] += 1.0 / posterior_s_variance(prior_info, info, factor) \
            - 1.0 / block[0, 0]
        if factor <= 1.0:
            return r_c
        self.rows_scaled += 1
        return factor * density - accel

