"""The fault hypothesis of a row and the common-offset test (ekf/outliers.py).

References: Bayes' rule written out with `scipy.stats.norm` densities; the offset's
least squares solved by `scipy.optimize.minimize_scalar`; χ² moments of Monte Carlo draws.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.stats import chi2, norm

from ekf.errors import ModelError
from ekf.outliers import common_offset, fault_probability, fault_threshold

#: Same closed form evaluated another way (densities vs log odds): relative agreement.
RTOL = 1e-10
#: The scalar minimizer's tolerance on the offset, in units of the innovation.
ATOL_OFFSET = 1e-6
#: Monte Carlo draws for the χ² moments, and the 5σ band of a mean of that many.
DRAWS = 20_000


def test_fault_probability_is_bayes_rule_with_the_two_densities():
    nu = np.array([0.0, 1.0, -3.0, 5.0, 12.0])
    S = np.array([4.0, 1.0, 2.0, 9.0, 16.0])
    p, kappa = 0.01, 10.0
    f_n = norm.pdf(nu, scale=np.sqrt(S))
    f_f = norm.pdf(nu, scale=kappa * np.sqrt(S))
    expected = p * f_f / (p * f_f + (1 - p) * f_n)
    got = fault_probability(nu ** 2 / S, prior=p, scale=kappa)
    np.testing.assert_allclose(got, expected, rtol=RTOL)
    # monotone in |ν|/σ, and the prior when the densities are equal (r² = 2 ln κ /(1−1/κ²))
    assert np.all(np.diff(got[[0, 1, 2, 4]]) > 0)
    r2_equal = 2 * np.log(kappa) / (1 - 1 / kappa ** 2)
    assert fault_probability(r2_equal, prior=p, scale=kappa) == pytest.approx(p, rel=RTOL)


@pytest.mark.parametrize("p, kappa, decision", [(0.01, 10.0, 0.5), (1e-3, 30.0, 0.9),
                                                (0.2, 3.0, 0.5)])
def test_threshold_is_where_the_posterior_reaches_the_decision(p, kappa, decision):
    r2 = fault_threshold(prior=p, scale=kappa, decision=decision)
    # Bayes with the densities at ν = √r², S = 1
    nu = np.sqrt(r2)
    f_n, f_f = norm.pdf(nu), norm.pdf(nu, scale=kappa)
    assert p * f_f / (p * f_f + (1 - p) * f_n) == pytest.approx(decision, rel=1e-9)


def test_the_papers_three_sigma_gate_is_one_fault_model():
    """SEEDS.md §3 / ekf/outliers.py: p = 0.1 and κ ≈ 9.517 give the 3σ gate (r² = 9)."""
    assert fault_threshold(prior=0.1, scale=9.517) == pytest.approx(9.0, abs=1e-3)


def test_common_offset_is_the_weighted_least_squares_offset(rng):
    m = 7
    A = rng.normal(size=(m, m))
    S = A @ A.T + m * np.eye(m)
    members = np.array([1, 1, 1, 1, 0, 1, 0], dtype=bool)
    nu = rng.multivariate_normal(np.zeros(m), S) + 25.0 * members
    offset, var, nis_off, nis_res = common_offset(nu, S, members)
    S_inv = np.linalg.inv(S)
    d = members.astype(float)

    def cost(a):
        e = nu - d * a
        return e @ S_inv @ e

    best = minimize_scalar(cost, bracket=(0.0, 50.0), tol=1e-12)
    assert offset == pytest.approx(best.x, abs=ATOL_OFFSET)
    assert nis_res == pytest.approx(cost(best.x), rel=1e-8)
    assert var == pytest.approx(1.0 / (d @ S_inv @ d), rel=RTOL)
    assert nis_off + nis_res == pytest.approx(nu @ S_inv @ nu, rel=RTOL)
    assert nis_off == pytest.approx(offset ** 2 / var, rel=RTOL)


def test_without_an_offset_the_two_parts_are_chi_square(rng):
    """Means of χ²₁ and χ²_{m−1} over many draws, within 5σ of their sampling error."""
    m = 5
    A = rng.normal(size=(m, m))
    S = A @ A.T + np.eye(m)
    members = np.array([1, 1, 1, 0, 1], dtype=bool)
    L = np.linalg.cholesky(S)
    parts = np.array([common_offset(L @ rng.normal(size=m), S, members)[2:]
                      for _ in range(DRAWS)])
    for k, dof in enumerate((1, m - 1)):
        band = 5 * np.sqrt(chi2.var(dof) / DRAWS)
        assert abs(parts[:, k].mean() - dof) < band


def test_bad_arguments_are_refused():
    with pytest.raises(ModelError, match="prior"):
        fault_probability(1.0, prior=0.0, scale=10.0)
    with pytest.raises(ModelError, match="scale"):
        fault_probability(1.0, prior=0.1, scale=1.0)
    with pytest.raises(ModelError, match="decision"):
        fault_threshold(prior=0.1, scale=10.0, decision=1.0)
    with pytest.raises(ModelError, match="member"):
        common_offset(np.ones(2), np.eye(2), np.zeros(2, dtype=bool))
    with pytest.raises(ModelError, match="common_offset"):
        common_offset(np.ones(2), np.eye(3), np.ones(2, dtype=bool))
