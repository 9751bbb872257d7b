"""Gate thresholds against printed χ² tables (Abramowitz & Stegun, table 26.8) and the
trace test of Ivanov et al. 2021."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.errors import ModelError
from ekf.gating import Gate, chi2_threshold

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
