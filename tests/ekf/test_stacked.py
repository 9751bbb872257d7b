"""Members of a bank propagated together (`ekf.stacked.propagate_members`) against the
engine driven member by member (`ekf.CdFilter.reset` + `propagate`): the same posteriors
and per-step outputs to the bit, and the same errors."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.cd_filter import CdFilter
from ekf.errors import FilterDivergedError, ModelError
from ekf.series import InputSeries
from ekf.stacked import propagate_members


@pytest.fixture
def engine(linear_system):
    """The engine of a damped oscillator with a continuous measurement of its position."""
    system = linear_system(A=np.array([[0.0, 1.0], [-0.4, -0.1]]),
                           G=np.array([[0.0], [1.0]]), H=np.array([[1.0, 0.0]]),
                           D=np.zeros((1, 1)))
    return CdFilter(system.model("stacked_test"))


def _members(rng, k: int):
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 40)])       # jittered samples
    priors, series = [], []
    for _ in range(k):
        L = rng.normal(size=(2, 2))
        priors.append((rng.normal(size=2), L @ L.T + 0.1 * np.eye(2)))
        series.append(InputSeries(t=t, u=np.zeros((t.size, 0)),
                                  q_c=rng.uniform(0.01, 0.1, (t.size, 1)),
                                  r_c=rng.uniform(0.5, 2.0, (t.size, 1)),
                                  z_c=rng.normal(size=(t.size, 1))))
    return priors, series


def _as_one_by_one(engine, priors, series, outputs=("x_next", "P_next", "x_filt", "P_filt",
                                                    "innov", "S", "nis", "Phi")) -> None:
    """`propagate_members` of the members against the engine's ``reset`` + ``propagate``
    member by member: posteriors and the per-step `outputs`, to the bit."""
    together = propagate_members(engine, priors, series)
    for (x0, P0), samples, member in zip(priors, series, together):
        engine.reset(x0, P0)
        steps = engine.propagate(samples)
        np.testing.assert_array_equal(member.x, engine.x)
        np.testing.assert_array_equal(member.P, engine.P)
        for name in outputs:
            np.testing.assert_array_equal(getattr(member.outputs, name), getattr(steps, name))


def test_members_together_equal_the_engine_one_by_one(engine):
    _as_one_by_one(engine, *_members(np.random.default_rng(3), 4))


def test_a_single_sample_is_the_prior_symmetrized(engine):
    P0 = np.array([[2.0, 0.5 + 1e-12], [0.5, 1.0]])
    member, = propagate_members(engine, [(np.array([1.0, -1.0]), P0)],
                                [InputSeries(t=np.array([3.0]), u=np.zeros((1, 0)),
                                             q_c=np.array([0.1]))])
    assert member.outputs is None
    np.testing.assert_array_equal(member.P, 0.5 * (P0 + P0.T))
    np.testing.assert_array_equal(member.x, [1.0, -1.0])


def test_bad_priors_fail_as_the_engine_does(engine):
    priors, series = _members(np.random.default_rng(4), 2)
    with pytest.raises(ModelError, match="2 priors for 1 sample series"):
        propagate_members(engine, priors, series[:1])
    with pytest.raises(ModelError, match="x0 must be"):
        propagate_members(engine, [(np.zeros(3), np.eye(3))], series[:1])
    with pytest.raises(FilterDivergedError, match="initial covariance"):
        propagate_members(engine, [(np.zeros(2), -np.eye(2))], series[:1])


def test_one_bad_prior_among_members_fails_as_the_engine_does(engine):
    """The members' priors are checked together (`ekf.stacked._checked_priors`); one that
    is not positive definite among good ones raises what `CdFilter.reset` raises."""
    priors, series = _members(np.random.default_rng(5), 3)
    priors[1] = (priors[1][0], -priors[1][1])
    engine.reset(*priors[0])                            # the good ones are fine alone
    with pytest.raises(FilterDivergedError, match="initial covariance") as alone:
        engine.reset(*priors[1])
    with pytest.raises(FilterDivergedError, match="initial covariance") as together:
        propagate_members(engine, priors, series)
    assert str(together.value) == str(alone.value)


def test_shared_inputs_and_held_rows_equal_the_engine_one_by_one(engine):
    """Members whose samples share one array (`ekf.stacked._field_together` broadcasts
    it) and hold one row of ``q_c`` each over their samples (broadcast too), one member
    without ``z_c`` (zeros): the engine's numbers member by member, to the bit."""
    rng = np.random.default_rng(6)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 30)])
    u, r_c = np.zeros((t.size, 0)), rng.uniform(0.5, 2.0, (t.size, 1))
    priors, series = [], []
    for k in range(3):
        L = rng.normal(size=(2, 2))
        priors.append((rng.normal(size=2), L @ L.T + 0.1 * np.eye(2)))
        series.append(InputSeries(t=t, u=u, q_c=rng.uniform(0.01, 0.1, 1), r_c=r_c,
                                  z_c=None if k == 1 else rng.normal(size=(t.size, 1))))
    _as_one_by_one(engine, priors, series)


def test_members_without_measurements_and_ragged_priors(engine):
    """Every member without ``z_c`` (zeros: one array for all) gives the engine's numbers
    member by member; priors of two shapes (they do not stack) fail as the engine fails
    on the first bad one."""
    priors, series = _members(np.random.default_rng(8), 3)
    series = [InputSeries(t=s.t, u=s.u, q_c=s.q_c, r_c=s.r_c, z_c=None) for s in series]
    _as_one_by_one(engine, priors, series)
    with pytest.raises(ModelError, match=r"x0 must be \(2,\) and P0 \(2, 2\); got \(3,\)"):
        propagate_members(engine, [priors[0], (np.zeros(3), np.eye(3))], series[:2])
