r"""The blend of a sample straddling a curvature step, linearized at that sample's prior.

A sample's centripetal term across a horizontal curvature step is the blend of the two
sides over the distance run in its interval, a ramp of width ``w = |v| dt`` in ``s``
(`railnav.filters.geometry_noise`, "Interval means"). `geometry_noise.statistical_parameters`
fits each sample's ramp once per chunk, by regression over the *chunk's* prior. Where
``w`` is not wide against σ_s (0.2 m at 20 m/s, against σ_s 0.04–0.6 m on the switch
network) the ramp is far from a line over that prior, and the lines are wrong once the
chunk's first rows have moved ``s``: each later sample keeps a line with the ramp's
average slope over the chunk's prior, which the moved estimate reads past the ramp's flat
ends, and which lends ``s`` the information of that slope.

Measured (`benchmarks/bench_network_switches.py`, seed 9, de48e11): at 383.10 s the
straddling sample moved the estimate from 0.41 m behind the truth to 0.03 m behind, the
next two samples, on their chunk-prior lines, took it back to 0.12 m while σ_s went 0.21
→ 0.10 m, and the chunk ended 0.18 m behind at σ_s 0.073 m; at the step at 385.47 s the
prior was 0.19 m behind (2.6σ), the straddling sample saw the 50 % blend where its line
predicted the near side (innovation 6.8σ), and the chunk ended 0.074 m behind at σ_s
0.018 m (z −4.0); the next step's straddling sample gave a NIS of 366, and the network
status said ``degraded`` for 10 s.

**The remedy: each straddling sample at its own prior.** A chunk whose samples' windows
hold a step (`geometry_noise.across_a_step`) is stepped up to each such sample (trial
steps through the engine's propagator, the engine's own state untouched), and that
sample's ramp is regressed over the filter's prior *there* — after the rows before it —
(`geometry_noise.blend_parameters`: mean and regression slope of the interval means, and
the remainder's variance, over ``N(s, σ_s²)`` at that sample); the chunk then runs with
those lines. It is the statistically linearized filter done sample by sample (Gelb 1974,
§6.2) instead of once per chunk; chunks without a step nearby run as before.

**Correlation time: the chunk's.** The remainder's density stays ``var · T_c`` with
``T_c = 2 σ_s / |v|`` of the *chunk's* prior (`geometry_noise.remainder_correlation_s`):
the samples' remainders are functions of one error of ``s`` against one step while it
runs through the window, as `railnav.filters.one_sided` argues per episode. With ``T_c``
taken from each sample's own, shrinking, σ_s, a run of samples still short of the step
("not yet", one-sided information) took σ_s from 0.63 to 0.018 m with the error 0.49 m
(seed 5, 254.37 s: z 28, the status ``degraded`` for 12 s).

**Tried and not kept: posterior linearization** (García-Fernández et al. 2015: each
sample's line regressed again over the posterior it gave, from the same prior). Seeds 1,
5, 7, 9 of the switch network: epochs beyond 3σ_s 0 (max |z| 2.9) at the prior only, 4
(3.6) with one posterior pass, 6 (8.9) with two; a whole cycle re-run over the previous
run's posteriors (``T_c`` from each sample's σ_s) gave 23 not-``ok`` epochs over ten seeds
where this gives 4. A
truncation ("not past the step yet") taken as a Gaussian posterior is narrow next to the
step, the ramp's regression over it steep, and the re-fitted rows collapse σ_s where the
truth is not.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.series import InputSeries
from railnav.filters.geometry_noise import (across_a_step, blend_parameters,
                                            remainder_correlation_s)
from railnav.filters.held_remainder import held_density
from railnav.filters.one_sided_rows import OneSidedRows

__all__ = ["StepBlend", "relinearized"]

Array = npt.NDArray[np.float64]

#: A step time matches a sample time within this, s.
_TIME_TOL_S = 1e-9


class StepBlend:
    """The straddling samples of a filter's latest chunk, and their lines at a prior
    (module docstring).

    Parameters
    ----------
    grid : railnav.filters.track_grid.TrackParameterGrid
    i_s, i_v : int
        Indices of ``s`` and ``v`` in the state.
    noise_names : sequence of str
        The process noise names (the accelerometer's ``w_fy``, ``w_fz``).
    """

    def __init__(self, grid, i_s: int, i_v: int, noise_names) -> None:
        self.grid, self.i_s = grid, int(i_s)
        self._chunk: dict | None = None
        #: The bound on the one-sided rows' information (`railnav.filters.one_sided_rows`).
        self.one_sided = OneSidedRows(grid.curvature_steps, i_s, i_v,
                                      [list(noise_names).index(n) for n in ("w_fy", "w_fz")])

    def record(self, t: Array, s_pred: Array, params: Array, geometry_r_c: Array, *,
               sigma_s_m: float, speed_mps: float, step_s: float, held_s: float) -> None:
        """Keep a chunk's samples (times `t`, s, shape (M,); predicted path `s_pred`, m)
        whose prior window holds a step (`geometry_noise.across_a_step`), with their
        parameters (M, 16) and geometry noise densities (M, 2), (m/s²)²·s, as the chunk's
        inputs have them; the chunk prior's σ_s (m) and speed (m/s), the sample step and
        the chunk's length (s)."""
        rows = across_a_step(self.grid, s_pred, sigma_s_m=sigma_s_m,
                             interval_m=speed_mps * step_s)
        if not rows.any():
            self.one_sided.end()
        self._chunk = None if not rows.any() else {
            "t": np.asarray(t, dtype=float), "rows": rows, "params": params,
            "r_c": np.array(geometry_r_c, dtype=float), "speed": float(speed_mps),
            "step": float(step_s), "held": float(held_s),
            "correlation": remainder_correlation_s(sigma_s_m=sigma_s_m, speed_mps=speed_mps,
                                                   step_s=step_s)}

    @property
    def pending(self) -> bool:
        """Whether the latest chunk has straddling samples."""
        return self._chunk is not None

    def steps(self, t_steps: Array) -> list[tuple[int, int]]:
        """The straddling samples among a run's steps (start times `t_steps`, s, shape
        (N,)): ``(step, sample)`` index pairs, in time order."""
        chunk = self._chunk
        if chunk is None or t_steps.size == 0:
            return []
        t = chunk["t"]
        at = np.minimum(np.searchsorted(t_steps, t - _TIME_TOL_S), t_steps.size - 1)
        found = chunk["rows"] & (np.abs(t_steps[at] - t) <= _TIME_TOL_S)
        return [(int(at[j]), int(j)) for j in np.flatnonzero(found)]

    def line(self, sample: int, *, s_m: float, sigma_s_m: float) -> tuple[Array, Array]:
        """Sample `sample`'s parameters (16,) with its blend regressed over ``s ~ N(s_m,
        sigma_s_m²)`` (m), and the change of its geometry density from the chunk's
        (2,), (m/s²)²·s (the chunk's correlation time: module docstring)."""
        chunk, k = self._chunk, int(sample)
        one = slice(k, k + 1)
        params, variance = blend_parameters(self.grid, chunk["params"][one],
                                            np.ones(1, dtype=bool), s_m=np.array([s_m]),
                                            sigma_s_m=np.array([sigma_s_m]),
                                            speed_mps=chunk["speed"],
                                            interval_m=chunk["speed"] * chunk["step"])
        density = held_density(variance, params, sigma_s_m=sigma_s_m,
                               speed_mps=chunk["speed"], correlation_s=chunk["correlation"],
                               held_s=chunk["held"])
        return params[0], density[0] - chunk["r_c"][k]


def relinearized(filt, series: InputSeries, trial, prior: tuple[Array, Array]
                 ) -> InputSeries:
    """The run `series` of `filt`'s latest inputs with each straddling sample's blend
    regressed over the filter's prior at that sample (module docstring); `series` itself
    when there is none (or no ``filt.step_blend``).

    Parameters
    ----------
    filt : railnav.filters.protocol.Filter
        With a `StepBlend` as ``filt.step_blend`` (else nothing is done).
    series : InputSeries
        The run's samples, shaped for the engine (`ekf.InputSeries.shaped`), the first
        at the prior: the filter's latest ``inputs`` (any allowance the driver adds to
        ``r_c`` included).
    trial : callable
        ``trial(x, P_packed, samples) -> StepOutputs``: the steps of `samples` (an
        `InputSeries`) from the prior ``(x, P_packed)`` at their first sample
        (`ekf.CdFilter.steps_from`).
    prior : (ndarray (n,), ndarray (n(n+1)/2,))
        The state and packed covariance at ``series.t[0]``.
    """
    blend = getattr(filt, "step_blend", None)
    if blend is None or not blend.pending:
        return series
    steps = blend.steps(series.t[:-1])
    if not steps:
        return series
    i_s = blend.i_s
    p, r_c = series.p.copy(), series.r_c.copy()
    q_c = np.atleast_2d(series.q_c)
    (x, P), start = prior, 0
    for k, sample in steps:
        if k > start:                                   # step on to sample k's prior
            out = trial(x, P, replace(series.slice(start, k + 1), p=p[start:k + 1],
                                      r_c=r_c[start:k + 1]))
            x, P, start = out.x_next[-1], out.P_next[-1], k
        cov = unpack_sym(P)
        sigma = float(np.sqrt(max(cov[i_s, i_s], 0.0)))
        p[k], delta = blend.line(sample, s_m=float(x[i_s]), sigma_s_m=sigma)
        t_k = float(series.t[k])
        r_c[k] = blend.one_sided.bound(x, cov, p[k], series.r_c[k] + delta,
                                       q_c[min(k, q_c.shape[0] - 1)], t_s=t_k,
                                       step_s=float(series.t[k + 1]) - t_k)
    return replace(series, p=p, r_c=r_c)
