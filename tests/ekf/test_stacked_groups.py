"""`ekf.stacked.propagate_members` with members that cannot all go in one call (other
sample times, other lengths, a single sample), with bad samples and with only some
per-step outputs kept: against the engine driven member by member (`ekf.CdFilter.reset`
+ `propagate`), to the bit, and its errors."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.cd_filter import CdFilter
from ekf.errors import ModelError
from ekf.series import InputSeries
from ekf.stacked import propagate_members
from ekf.step import STEP_OUTPUTS


@pytest.fixture
def engine(linear_system):
    system = linear_system(A=np.array([[0.0, 1.0], [-0.4, -0.1]]),
                           G=np.array([[0.0], [1.0]]), H=np.array([[1.0, 0.0]]),
                           D=np.zeros((1, 1)))
    return CdFilter(system.model("stacked_groups"))


def _member(rng, t: np.ndarray, *, q_per_sample: bool = True):
    L = rng.normal(size=(2, 2))
    prior = (rng.normal(size=2), L @ L.T + 0.1 * np.eye(2))
    q_c = rng.uniform(0.01, 0.1, (t.size, 1)) if q_per_sample else np.array([0.05])
    return prior, InputSeries(t=t, u=np.zeros((t.size, 0)), q_c=q_c,
                              r_c=rng.uniform(0.5, 2.0, (t.size, 1)),
                              z_c=rng.normal(size=(t.size, 1)))


def _one_by_one(engine, prior, series):
    engine.reset(*prior)
    return engine.propagate(series), engine.x.copy(), engine.P.copy()


def test_members_of_other_times_and_lengths_equal_the_engine(engine, rng):
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 30)])
    other = t + 0.01                                         # same length, other times
    members = [_member(rng, t), _member(rng, other), _member(rng, t[:12]),
               _member(rng, t, q_per_sample=False), _member(rng, t[:1])]
    together = propagate_members(engine, [m[0] for m in members], [m[1] for m in members])
    for (prior, series), member in zip(members, together):
        steps, x, P = _one_by_one(engine, prior, series)
        np.testing.assert_array_equal(member.x, x)
        np.testing.assert_array_equal(member.P, P)
        if steps is None:
            assert member.outputs is None
            continue
        for name in STEP_OUTPUTS:
            np.testing.assert_array_equal(getattr(member.outputs, name), getattr(steps, name))


def test_only_the_kept_outputs(engine, rng):
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 20)])
    members = [_member(rng, t) for _ in range(3)]
    together = propagate_members(engine, [m[0] for m in members], [m[1] for m in members],
                                 keep=("innov", "S"))
    for (prior, series), member in zip(members, together):
        steps, x, P = _one_by_one(engine, prior, series)
        np.testing.assert_array_equal(member.x, x)
        np.testing.assert_array_equal(member.outputs.innov, steps.innov)
        np.testing.assert_array_equal(member.outputs.S, steps.S)
        assert member.outputs.P_filt is None and member.outputs.Phi is None


@pytest.mark.parametrize("field, value, message", [
    ("r_c", np.nan, "r_c has non-finite values"),
    ("q_c", -1.0, "noise spectral densities must be >= 0"),
    ("t", np.nan, "sample times must be finite and strictly increasing")])
def test_bad_samples_fail_as_the_engine_does(engine, rng, field, value, message):
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 10)])
    members = [_member(rng, t) for _ in range(3)]
    bad = getattr(members[1][1], field).copy()
    bad[4] = value
    members[1] = (members[1][0], InputSeries(**{**members[1][1].__dict__, field: bad}))
    with pytest.raises(ModelError, match=message):
        _one_by_one(engine, *members[1])
    with pytest.raises(ModelError, match=message):
        propagate_members(engine, [m[0] for m in members], [m[1] for m in members])
