"""The linearization window of the step (``StepOptions.jacobian_window_s``, ekf/step.py):
`window_median` against `numpy.median` of each window taken in a plain loop; the step with
the window against the NumPy reference step with ``H`` at ``u_lin``; the window off is the
step without the option, to the bit."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.cd_filter import CdFilter, FilterConfig, step_data
from ekf.errors import ModelError
from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import Propagator
from ekf.series import InputSeries
from ekf.step import StepData, StepOptions, window_median
from tests.support.ekf_examples import attitude_speed_clock_numpy, attitude_speed_clock_toy
from tests.support.ekf_reference import reference_step

#: Relative agreement of two implementations of the same floating-point algorithm
#: (as tests/ekf/test_step.py).
RTOL_SAME_ALGORITHM = 1e-10
#: Accumulated roundoff of 150 steps of ~1e3 flops, relative to the prior's covariance.
ROUNDOFF_OF_PRIOR = 1e-14
DT = 0.01  # s, 100 Hz
WINDOW_S = 0.05  # s: 5 to 6 samples at 100 Hz (odd and even counts, cut at the ends)


def _loop_median(t, u, window_s):
    """The running median the slow way: each window (centred, shrunk at the ends to the
    samples there are) selected and `np.median`-ed."""
    out = []
    for t_k in t:
        half = min(0.5 * window_s, t_k - t[0], t[-1] - t_k)
        out.append(np.median(u[np.abs(t - t_k) <= half + 1e-9], axis=0))
    return np.array(out)


@pytest.mark.parametrize("window_s", [0.0, 0.03, 0.25, 10.0])
def test_window_median_equals_per_sample_median(rng, window_s):
    """Irregular times (jitter, a gap, an inserted sample) so windows hold odd and even
    counts, and windows shrunk at both ends (the first and last samples alone); 10 s:
    every window reaches an end of the series."""
    t = np.cumsum(rng.uniform(0.004, 0.016, 400))
    t[200:] += 0.3                                     # a gap
    t = np.sort(np.concatenate([t, [t[100] + 1e-4]]))  # an inserted sample
    u = rng.normal(size=(t.size, 6))
    got = window_median(t, u, window_s)
    want = _loop_median(t, u, window_s)
    assert np.array_equal(got, want)
    assert np.array_equal(got[[0, -1]], u[[0, -1]])
    if window_s == 0.0:
        assert np.array_equal(got, u)


@pytest.mark.parametrize("at", [3, 10, 17])
def test_window_median_keeps_a_step_at_its_sample(at):
    """A step of the input (a curve entered without a transition) stays at its sample,
    mid-series and near either end (a one-sided window at the ends would move it)."""
    t = np.arange(21) * DT
    u = np.where(np.arange(21) >= at, 100.0, 0.0)[:, None]
    assert np.array_equal(window_median(t, u, 10.5 * DT), u)


def test_window_median_of_a_constant_plus_an_outlier_is_the_constant():
    """A median, not a mean: one outlier in a window of 5 does not move it."""
    t = np.arange(20) * DT
    u = np.full((20, 1), 3.0)
    u[10] = 1e3
    assert np.array_equal(window_median(t, u, 4.5 * DT), np.full((20, 1), 3.0))


def test_window_median_rejects_bad_shapes():
    with pytest.raises(ModelError):
        window_median(np.arange(3.0), np.zeros((4, 2)), 0.1)
    with pytest.raises(ModelError):
        window_median(np.arange(3.0), np.zeros((3, 2)), -0.1)


def _toy_series(rng, n_steps: int) -> InputSeries:
    u = np.zeros((n_steps + 1, 6))
    u[:, 2] = 9.81
    u[:, 3:] = rng.normal(0.0, 0.02, (n_steps + 1, 3))
    u[:, :3] += rng.normal(0.0, 0.05, (n_steps + 1, 3))
    t = np.arange(n_steps + 1) * DT
    return InputSeries(t=t, u=u, p=np.zeros((n_steps + 1, 0)),
                       z_c=rng.normal(0, 1e-3, (n_steps + 1, 2)),
                       q_c=np.tile([1e-10] * 3 + [1e-12] * 3, (n_steps + 1, 1)),
                       r_c=np.full((n_steps + 1, 2), 1e-6))


X0 = np.array([0.5, 0.01, -0.02, 0.0, 20.0, 100.0, 1.0])
P0 = np.diag([1.0, 0.1, 0.1, 1e6, 1.0, 1e6, 1.0])


@pytest.mark.parametrize("backend", ["compiled", "casadi"])
def test_window_step_matches_numpy_reference_with_H_at_the_median(rng, backend):
    """The toy's ``H`` depends on the gyro input (``∓u_ω``): with the window, every use
    of ``H`` (update, ``Φ̃``, the prediction's residual) is at `window_median`'s input,
    ``h_c`` and ``D`` at the raw sample (reference: tests/support/ekf_reference.py)."""
    n_steps = 150
    model = attitude_speed_clock_toy()
    opts = StepOptions(jacobian_window_s=WINDOW_S)
    prop = Propagator(model, opts, backend=backend)
    series = _toy_series(rng, n_steps)
    d = step_data(prop, series)
    assert prop.data.n_lin == model.n_u and d.shape[1] == StepData.of(model).size + model.n_u
    out = prop.run(X0, pack_sym(P0), d)
    u, u_lin = series.u, window_median(series.t, series.u, WINDOW_S)
    assert not np.array_equal(u_lin, u)
    model_np, x, P = attitude_speed_clock_numpy(), X0, P0
    for k in range(n_steps):
        ref = reference_step(model_np, x, P, u[k], u[k + 1], np.zeros(0),
                             z_c=series.z_c[k], dt=DT, q_c=series.q_c[k],
                             r_c=series.r_c[k], opts=opts, u_lin=u_lin[k])
        x, P = ref["x_next"], ref["P_next"]
    scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
    # the pitch variance collapses from 0.1 to 3e-7 rad²: its roundoff is that of the prior
    prior_scale = np.sqrt(np.outer(np.diag(P0), np.diag(P0)))
    np.testing.assert_allclose(out.x_next[-1], x, rtol=RTOL_SAME_ALGORITHM, atol=1e-12)
    assert np.all(np.abs(unpack_sym(out.P_next[-1]) - P)
                  <= RTOL_SAME_ALGORITHM * scale + ROUNDOFF_OF_PRIOR * prior_scale)
    np.testing.assert_allclose(out.Phi[-1].reshape(7, 7), ref["Phi"],
                               rtol=RTOL_SAME_ALGORITHM, atol=1e-14)
    # ... and it is not the step at the raw samples
    x_raw, P_raw = X0, P0
    for k in range(n_steps):
        raw = reference_step(model_np, x_raw, P_raw, u[k], u[k + 1], np.zeros(0),
                             z_c=series.z_c[k], dt=DT, q_c=series.q_c[k],
                             r_c=series.r_c[k], opts=opts)
        x_raw, P_raw = raw["x_next"], raw["P_next"]
    assert not np.allclose(P_raw, P, rtol=1e-6, atol=0)


def test_window_off_is_the_step_without_the_option_to_the_bit(rng):
    """``jacobian_window_s=0``: the same data layout, the same function, the same bits
    as `StepOptions()` (today's step), through the driver."""
    model = attitude_speed_clock_toy()
    series = _toy_series(rng, 300)
    assert StepData.of(model, StepOptions(jacobian_window_s=0.0)) == StepData.of(model)
    runs = []
    for opts in (StepOptions(), StepOptions(jacobian_window_s=0.0)):
        engine = CdFilter(model, FilterConfig(step=opts, store_every=1))
        runs.append(engine.run(series, [], x0=X0, P0=P0))
        assert engine.propagator.data.size == StepData.of(model).size
    a, b = runs
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P_diag, b.P_diag)
    # the window on changes the run (the test above checks how)
    on = CdFilter(model, FilterConfig(step=StepOptions(jacobian_window_s=WINDOW_S)))
    assert not np.array_equal(on.run(series, [], x0=X0, P0=P0).P_diag, a.P_diag)


def test_window_needs_sample_times():
    data = StepData.of(attitude_speed_clock_toy(), StepOptions(jacobian_window_s=0.1))
    with pytest.raises(ModelError, match="sample"):
        data.assemble(np.zeros((3, 6)), np.zeros((2, 0)), np.zeros((2, 2)), np.full(2, DT),
                      np.ones((2, 6)), np.ones((2, 2)))


def test_negative_window_is_refused():
    with pytest.raises(ModelError):
        StepOptions(jacobian_window_s=-0.5)
