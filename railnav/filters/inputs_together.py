"""A bank's constrained filters' inputs over the same samples, stacked where alike.

`railnav.filters.constrained.ConstrainedFilter.inputs` turns a chunk of IMU samples into
one filter's inputs: the along-track path predicted from its prior, the track
parameters on a grid along it, the geometry noise and the process noise density. A bank
of hypotheses (`railnav.navigation.hypothesis_step`) asks for them once per hypothesis and
cycle over the same samples; each filter's own call costs ~50 µs, almost all of it the
fixed cost of small NumPy calls. `inputs_together` does, for filters of one layout:

* the along-track accelerations and predicted paths of all, as (K, M) arrays
  (`railnav.filters.reference_path.paths_together`);
* each filter's grid rows on its own track, the nearest nodes of all found by one search
  (`railnav.filters.track_grid.parameters_together`: each grid's own window);
* the short cut of `railnav.filters.geometry_noise.statistical_parameters` (a prior inside
  one straight section: no remainder) tested for all (`straight_priors`), its zero
  variance's density stacked; the filters whose prior is not on a straight take their
  own `statistical_parameters` and `held_density`;
* the chunk's median step once, the along-track force once per low-pass state
  (`forces_together`), the bias steps' densities in one call (`bias_together`).

Each filter gets the numbers of its own `inputs`, to the bit (the same elementwise
operations; `tests/railnav/filters/test_inputs_together.py`), and its state (the grid's
window, ``_chunk_end``, the along-force memory) is left where its own call leaves it.
Filters of several layouts, or one filter object twice, go one by one.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.filters.along_force_noise import forces_together
from railnav.filters.geometry_noise import (remainder_correlation_s, statistical_parameters,
                                            straight_priors)
from railnav.filters.held_remainder import held_density
from railnav.filters.path_noise import bias_together
from railnav.filters.reference_path import paths_together
from railnav.filters.track_grid import parameters_together

__all__ = ["inputs_together", "chunk_median_step", "sample_steps"]

Array = npt.NDArray[np.float64]


def chunk_median_step(t: Array, t_prev: float) -> float:
    """The median step of samples ``t`` after ``t_prev`` (s): the constrained filter's
    correlation step when no nominal sample interval is set."""
    return float(np.median(np.diff(np.concatenate([[t_prev], t])))) if t.size > 1 \
        else float(t[0] - t_prev)


def sample_steps(t: Array, step: float) -> Array:
    """The step from each sample of `t`: ``np.diff(t)``, then the nominal `step` (s)."""
    steps = np.empty(max(t.size, 1))
    steps[:-1] = t[1:] - t[:-1]
    steps[-1] = step
    return steps


def inputs_together(filters, t: Array, u: Array, priors, t_prev: float) -> list:
    """`ConstrainedFilter.inputs` of each filter over samples `t`, `u` from its prior
    ``priors[k] = (x_prev, P_prev)`` (module docstring). Returns each one's tuple
    ``(u, p, r_c)``, in order, with each filter's ``step_q_c`` set."""
    # the chunk's median step, for the filters without a nominal one: the same for all
    step = chunk_median_step(t, t_prev) if any(f.sample_interval_s is None for f in filters) \
        else None
    forces = forces_together([f._along for f in filters], t, u)
    if _stackable(filters) and t.size:
        pending = _starts_together(filters, t, u, priors, t_prev, step, forces)
    else:
        pending = [f._start_inputs(t, u, x, P, t_prev, chunk_step=step, along=along)
                   for f, (x, P), along in zip(filters, priors, forces)]
    return [f._finish_inputs(p, found) for f, p, found
            in zip(filters, pending, bias_together([f.path_noise for f in filters], pending))]


def _stackable(filters) -> bool:
    """Whether the filters' paths can be predicted as one array: distinct objects (each
    grid and memory touched once) of one state layout."""
    first = filters[0]
    return len({id(f) for f in filters}) == len(filters) and all(
        f._i == first._i and f._b_ax == first._b_ax for f in filters)


def _starts_together(filters, t: Array, u: Array, priors, t_prev: float,
                     step: float | None, forces: list) -> list[dict]:
    """Each filter's ``_start_inputs`` (module docstring)."""
    X = np.array([x for x, _ in priors], dtype=float)
    accel, s_pred = paths_together(filters, t, u, X, t_prev)
    params = [f._path_parameters(s, found) for f, s, found in
              zip(filters, s_pred, parameters_together([f._grid for f in filters], s_pred))]
    spread = [f.prior_spread(x, P) for f, (x, P) in zip(filters, priors)]
    chunk_steps = [f.chunk_step(t, t_prev, step) for f in filters]
    sigma = np.array([sigma for sigma, _ in spread])
    speed = np.array([speed for _, speed in spread])
    interval = speed * np.array(chunk_steps)
    straight = straight_priors([f.track for f in filters], s_pred, sigma_s_m=sigma,
                               interval_m=interval)
    correlation = [remainder_correlation_s(sigma_s_m=a, speed_mps=v, step_s=dt)
                   for (a, v), dt in zip(spread, chunk_steps)]
    # the straight ones' variance is zero: its density, var · T_c, stacked
    zero = np.zeros(s_pred.shape + (2,)) * np.array(correlation)[:, None, None]
    held_s = float(t[-1]) - t_prev
    shared: dict[float, Array] = {}                 # `sample_steps` per chunk step, read-only
    for step_k in chunk_steps:
        if step_k not in shared:
            shared[step_k] = sample_steps(t, step_k)
            shared[step_k].flags.writeable = False
    out = []
    for k, f in enumerate(filters):
        x, P = priors[k]
        (sigma_k, speed_k), p, r_c = spread[k], params[k], zero[k]
        if not straight[k]:
            p, variance = statistical_parameters(f._grid, p, sigma_s_m=sigma_k,
                                                 speed_mps=speed_k, interval_m=interval[k],
                                                 s_m=s_pred[k])
            r_c = held_density(variance, p, sigma_s_m=sigma_k, speed_mps=speed_k,
                               correlation_s=correlation[k], held_s=held_s)
        out.append(f._pending(t, u, x, P, t_prev, accel=accel[k], s_pred=s_pred[k],
                              params=p, r_c=r_c, step=chunk_steps[k], along=forces[k],
                              speed=speed_k, sigma_s=sigma_k, steps=shared[chunk_steps[k]]))
    return out
