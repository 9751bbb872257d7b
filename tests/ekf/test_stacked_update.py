"""A bank's members updated together (`ekf.stacked.update_members`) against the engine's
own update of each member (`ekf.CdFilter.update`, i.e. `ekf.update.kalman_update`): the
same posteriors to the bit, for members with rows evaluated at their prior (stacked), a
member with a gated row, a member with a clock jump's covariance (`ekf.EpochRows`), rows
not evaluated yet, no rows, and members with different numbers of rows; and the same
error for an innovation covariance that is not positive definite."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.errors import FilterDivergedError
from ekf.gating import Gate
from ekf.model import MeasurementModel
from ekf.series import EpochRows
from ekf.stacked import update_members
from ekf.update import EvaluatedObservations, Observation

N_STATES = 7


@pytest.fixture
def engine(linear_system):
    """An engine with the row gate the navigator uses (a 7-state random walk)."""
    system = linear_system(A=np.zeros((N_STATES, N_STATES)), G=np.eye(N_STATES))
    return CdFilter(system.model("stacked_update_test"),
                    FilterConfig(gate=Gate(0.9999, scope="rows")))


@pytest.fixture(scope="module")
def row_model() -> MeasurementModel:
    """A nonlinear scalar row ``z = p[:n]·x + p[n] (p[:n]·x)²`` (its Jacobian depends on
    ``x``, as the GNSS rows' does)."""
    x, p = ca.SX.sym("x", N_STATES), ca.SX.sym("p", N_STATES + 1)
    lin = ca.dot(p[:N_STATES], x)
    return MeasurementModel.from_expression(x, p, lin + p[N_STATES] * lin ** 2, "row")


def _prior(rng):
    L = rng.normal(size=(N_STATES, N_STATES))
    return rng.normal(size=N_STATES), L @ L.T + 0.5 * np.eye(N_STATES)


def _rows(rng, model, x, m: int, *, evaluated: bool = True, outlier: bool = False):
    p = np.column_stack([rng.normal(size=(m, N_STATES)), rng.uniform(0.0, 0.01, m)])
    z_pred, H = model.evaluate(x, p)
    z = z_pred + rng.normal(size=m) + (1e4 if outlier else 0.0) * (np.arange(m) == 0)
    obs = Observation(model, z[:, None], rng.uniform(0.5, 2.0, m), p)
    if not evaluated:
        return [obs]
    return EvaluatedObservations([obs], x=x, innov=z - z_pred, H=H, R=obs.R,
                                 groups=np.arange(m))


def _assert_equal_one_by_one(engine, priors, rows):
    """`update_members` against each member's engine update, bit for bit."""
    together = update_members(engine, priors, rows)
    for (x, P), (x_ref, P_ref) in zip(together, _one_by_one(engine, priors, rows)):
        np.testing.assert_array_equal(x, x_ref)
        np.testing.assert_array_equal(P, P_ref)


def _one_by_one(engine, priors, rows):
    out = []
    for (x, P), one in zip(priors, rows):
        engine.x, engine.P = x, P
        if isinstance(one, EpochRows):
            engine.P = engine.P + one.jump_covariance
            one = one.observations
        engine.update(one)
        out.append((engine.x, engine.P))
    return out


def test_members_updated_together_equal_the_engine_one_by_one(engine, row_model):
    rng = np.random.default_rng(11)
    priors = [_prior(rng) for _ in range(9)]
    rows = [_rows(rng, row_model, x, 12) for x, _ in priors[:5]]
    rows.append(_rows(rng, row_model, priors[5][0], 12, outlier=True))      # gated row
    jump = np.zeros((N_STATES, N_STATES))
    jump[3, 3] = 25.0
    rows.append(EpochRows(_rows(rng, row_model, priors[6][0], 12), jump))   # a clock jump
    rows.append(_rows(rng, row_model, priors[7][0], 5, evaluated=False))     # not evaluated
    rows.append([])                                                          # no rows
    _assert_equal_one_by_one(engine, priors, rows)


def test_members_with_different_row_counts(engine, row_model):
    rng = np.random.default_rng(12)
    priors = [_prior(rng) for _ in range(6)]
    rows = [_rows(rng, row_model, x, m) for (x, _), m in zip(priors, (3, 9, 3, 9, 1, 3))]
    _assert_equal_one_by_one(engine, priors, rows)


def test_a_covariance_not_positive_definite_fails_as_the_engine_does(engine, row_model):
    rng = np.random.default_rng(13)
    priors = [_prior(rng) for _ in range(2)]
    rows = [_rows(rng, row_model, x, 4) for x, _ in priors]
    bad = -np.eye(N_STATES) * 1e6                   # a prior far from positive definite
    priors[1] = (priors[1][0], bad)
    with pytest.raises(FilterDivergedError):
        _one_by_one(engine, priors[1:], rows[1:])
    with pytest.raises(FilterDivergedError):
        update_members(engine, priors, rows)
