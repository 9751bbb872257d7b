"""The bound on the one-sided rows beside a curvature step (`railnav.filters.one_sided_rows`).

References: the truncated normal's variance from `scipy.stats.truncnorm` (a second
implementation of the truncation the bound promises to keep), and the rows' information
recomputed here from their Jacobian ``∂h/∂s = −v² l·d²u/ds²``, ``∂h/∂v = −2v l·du/ds``
(``l`` the lateral axis).

The rows are those of `railnav.filters.step_blend`: the blend of a 100 m/s sample (1 m per
10-ms interval) beside the step of a straight into a 100-m arc (v²Δκ = 100 m/s², the
ring of `tests/railnav/navigation/test_monitor.py`), regressed over each row's own prior
(`geometry_noise.blend_parameters`), with a tactical accelerometer's white noise.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import truncnorm

from railnav.filters.geometry_noise import blend_parameters
from railnav.filters.one_sided_rows import OneSidedRows
from railnav.filters.track_grid import TrackParameterGrid
from strapdown.reduced import cross_track_basis
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

STEP_M = 1000.0
SPEED_MPS = 100.0
DT_S = 0.01
#: The accelerometer's white noise density on each row, (m/s²)²·s (tactical: 0.05 mg/√Hz).
ACCEL_Q = (0.05e-3 * 9.81) ** 2
SIGMA_V_MPS = 1e-3


def _grid() -> TrackParameterGrid:
    track = Track([Section(STEP_M, 90.0, 0.0), Section(300.0, None, None, 1.0 / 100.0)],
                  Origin(50.45, 30.52, 100.0), WGS84)
    return TrackParameterGrid(track)


def _episode(grid, means_m, sigma0_m: float, *, bounded: bool = True):
    """Rows at ``means_m`` (one per 10-ms sample) from the prior σ ``sigma0_m``: each
    row's line at its own (s, v) prior, its density bounded (or not), and the prior
    updated by the lateral row's information on ``(s, v)`` (recomputed here from its
    Jacobian; ``v`` known to 1 mm/s, so that the propagation between rows adds nothing worth counting). Returns
    the bound and the variance of ``s`` before the first row and after each row."""
    bound = OneSidedRows(grid.curvature_steps, 0, 1, [0, 1])
    P = np.diag([sigma0_m ** 2, SIGMA_V_MPS ** 2])
    phi = np.array([[1.0, DT_S], [0.0, 1.0]])
    variances = [P[0, 0]]
    for k, mean in enumerate(means_m):
        params, variance = blend_parameters(grid, grid.parameters(np.array([mean]))[0],
                                            np.ones(1, dtype=bool), s_m=np.array([mean]),
                                            sigma_s_m=np.array([math.sqrt(P[0, 0])]),
                                            speed_mps=SPEED_MPS, interval_m=SPEED_MPS * DT_S)
        r_c = variance[0] * DT_S                                    # held for one sample
        if bounded:
            r_c = bound.bound(np.array([mean, SPEED_MPS]), P, params[0], r_c,
                              np.array([ACCEL_Q, ACCEL_Q]), t_s=k * DT_S, step_s=DT_S)
        lateral, _ = cross_track_basis(params[:, 7:10])
        du = params[0, 10:13] + params[0, 13:16] * (mean - params[0, 0])
        h = np.array([-SPEED_MPS ** 2 * float(params[0, 13:16] @ lateral[0]),
                      -2.0 * SPEED_MPS * float(du @ lateral[0])])
        info = np.outer(h, h) * DT_S / (r_c[0] + ACCEL_Q)          # the lateral row
        P = phi @ np.linalg.inv(np.linalg.inv(P) + info) @ phi.T
        variances.append(P[0, 0])
    return bound, np.array(variances)


#: The ring's rows (stop 34): the estimate dragged back to the step at every row, each
#: row's mean within half an interval of it (0.5 m), at σ_s 0.7 m.
RING_MEANS_M = STEP_M + np.array([0.0, 0.2, -0.1, 0.3, 0.1, -0.2, 0.4, 0.0])
SIGMA0_M = 0.7


def _far_side_allowance(means_m, sigma_m: float) -> float:
    """The largest ``1/Var − 1/σ²`` of ``N(mean, σ²)`` truncated at the step on the side
    away from its mean, over `means_m` (`scipy.stats.truncnorm`), 1/m²."""
    beta = -np.abs(means_m - STEP_M) / sigma_m
    return float(np.max(1.0 / (sigma_m ** 2 * truncnorm.var(-np.inf, beta)))
                 - 1.0 / sigma_m ** 2)


def test_rows_held_at_the_step_take_one_fraction_and_one_truncation():
    """The first row at the step is a fraction (not bounded); what the rows after it add
    to the precision of ``s`` is at most the far-side truncation's, ``1/Var[s | s > c] −
    1/σ²`` of the episode's prior on the side away from each row's mean
    (`scipy.stats.truncnorm`, at the row where that allows most)."""
    _, variances = _episode(_grid(), RING_MEANS_M, SIGMA0_M)
    allowed = _far_side_allowance(RING_MEANS_M[1:], SIGMA0_M)
    assert variances[1] < 0.5 * variances[0]                    # the fraction is taken
    assert 1.0 / variances[-1] - 1.0 / variances[1] <= allowed * (1.0 + 1e-6)


def test_without_the_bound_the_same_rows_collapse():
    """The reference for the test above: the same rows unbounded add far more than the
    truncation (the ring of stop 34: σ_s 0.97 → 0.068 m)."""
    _, variances = _episode(_grid(), RING_MEANS_M, SIGMA0_M, bounded=False)
    allowed = _far_side_allowance(RING_MEANS_M[1:], SIGMA0_M)
    assert 1.0 / variances[-1] - 1.0 / variances[1] > 3.0 * allowed
