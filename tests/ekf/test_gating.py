"""Gate thresholds against printed χ² tables (Abramowitz & Stegun, table 26.8) and the
trace test of Ivanov et al. 2021."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.errors import ModelError
from ekf.gating import Gate, chi2_quantile, chi2_threshold

#: Table values are printed to 3 decimals.
ATOL_TABLE = 5e-4


@pytest.mark.parametrize("probability,dof,table", [(0.95, 1, 3.841), (0.99, 2, 9.210),
                                                    (0.95, 10, 18.307), (0.999, 4, 18.467)])
def test_chi2_threshold_matches_table(probability, dof, table):
    assert abs(chi2_threshold(probability, dof) - table) <= ATOL_TABLE


def test_trace_gate_is_the_paper_rule():
    """εᵀε ≤ γ̃ tr(S): with S = I₂ and γ̃ = 9 the boundary is |ε|² = 18."""
    gate = Gate(kind="trace", trace_factor=9.0)
    assert gate.passes(np.array([3.0, 3.0]), np.eye(2))[0]
    assert not gate.passes(np.array([3.0, 3.01]), np.eye(2))[0]


@pytest.mark.parametrize("kwargs", [dict(probability=1.0), dict(kind="x"), dict(scope="y"),
                                    dict(trace_factor=0.0)])
def test_gate_rejects_bad_configuration(kwargs):
    with pytest.raises(ModelError):
        Gate(**kwargs)


@pytest.mark.parametrize("kind", ["chi2", "trace"])
def test_scalar_rows_fast_path_equals_row_by_row_test(kind, rng):
    """Reference: `Gate.passes` applied to each scalar row on its own."""
    m = 40
    A = rng.normal(size=(m, m))
    S = A @ A.T + m * np.eye(m)
    innov = rng.normal(size=m) * np.sqrt(np.diag(S)) * 2.5   # some rows fail
    gate = Gate(0.99, kind=kind, scope="rows", trace_factor=4.0)
    fast = gate.accepted_rows(innov, S, np.arange(m))
    slow = np.array([gate.passes(innov[[i]], S[[i]][:, [i]])[0] for i in range(m)])
    np.testing.assert_array_equal(fast, slow)
    assert 0 < fast.sum() < m


@pytest.mark.parametrize("dof", [1, 2, 3, 7, 16, 40, 700, 70000])
def test_chi2_quantile_is_scipy_stats_to_the_bit(dof):
    """Reference: ``scipy.stats.chi2.ppf`` (the module the engine no longer imports)."""
    from scipy.stats import chi2
    for probability in (1e-6, 0.025, 0.5, 0.95, 0.975, 0.9973, 0.9999, 0.999999):
        assert chi2_quantile(probability, dof) == chi2.ppf(probability, dof)
