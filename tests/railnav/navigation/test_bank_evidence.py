"""The evidence of an epoch on a common basis (`railnav.navigation.bank`): the rows seen
by every filter and used by one, each filter's log-likelihood over them against SciPy's
multivariate normal density, and to the bit against SciPy's Cholesky and triangular
solve (the LAPACK routines it calls directly)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.stats import multivariate_normal

from railnav.filters.fault_detection import ROW_STATUSES, EpochScreen
from railnav.navigation.bank import common_log_likelihoods, evidence_rows

#: Relative tolerance against SciPy's density: a few roundings of a sum of ~10 terms.
RTOL_LOG_LIKELIHOOD = 1e-12


def _screen(rng, keys, refused=()) -> EpochScreen:
    m = len(keys)
    A = rng.normal(size=(m, m))
    status = np.array([ROW_STATUSES[1] if k in refused else ROW_STATUSES[0] for k in keys],
                      dtype=object)
    return EpochScreen(keys=np.array(keys), innov=rng.normal(0.0, 3.0, m),
                       S=A @ A.T + m * np.eye(m), status=status,
                       fault_probability=np.zeros(m), clock_jump_m=float("nan"))


def test_rows_seen_by_all_and_used_by_one(rng):
    a = _screen(rng, ["G01/pr", "G02/pr", "G03/pr", "G04/pr"], refused=("G02/pr", "G03/pr"))
    b = _screen(rng, ["G02/pr", "G03/pr", "G04/pr", "G05/pr"], refused=("G03/pr",))
    assert evidence_rows([a, b]) == {"G02/pr", "G04/pr"}


def test_log_likelihoods_over_the_common_rows(rng):
    keys = [f"G{k:02d}/{kind}" for k in range(1, 7) for kind in ("pr", "rr")]
    screens = [_screen(rng, keys, refused=("G03/pr",)), _screen(rng, keys[::-1]),
               _screen(rng, keys[1:], refused=("G03/pr", "G05/rr"))]
    common = evidence_rows(screens)
    got = common_log_likelihoods(screens)
    assert np.array_equal(common_log_likelihoods(screens, common), got)   # rows given
    for j, e in enumerate(screens):
        idx = np.array([k for k, key in enumerate(e.keys) if key in common])
        nu, S = e.innov[idx], e.S[np.ix_(idx, idx)]
        density = multivariate_normal(mean=np.zeros(idx.size), cov=S).logpdf(nu)
        assert got[j] == pytest.approx(density, rel=RTOL_LOG_LIKELIHOOD)
        L = sla.cholesky(S, lower=True, check_finite=False)
        white = sla.solve_triangular(L, nu, lower=True, check_finite=False)
        same = -0.5 * (white @ white + 2.0 * np.sum(np.log(np.diag(L)))
                       + idx.size * np.log(2.0 * np.pi))
        assert got[j] == same


def test_no_common_row_is_no_evidence(rng):
    a = _screen(rng, ["G01/pr"], refused=("G01/pr",))
    b = _screen(rng, ["G01/pr"], refused=("G01/pr",))
    np.testing.assert_array_equal(common_log_likelihoods([a, b]), [0.0, 0.0])


def test_a_covariance_that_is_not_positive_definite_is_an_error(rng):
    a, b = _screen(rng, ["G01/pr", "G02/pr"]), _screen(rng, ["G01/pr", "G02/pr"])
    b.S[:] = [[1.0, 2.0], [2.0, 1.0]]
    with pytest.raises(np.linalg.LinAlgError, match="filter 1"):
        common_log_likelihoods([a, b])


def test_continuous_evidence_on_the_widest_covariance_of_each_step(rng):
    """`common_continuous_log_likelihoods` (packed covariances): at each step every
    hypothesis's innovation against the covariance of the largest determinant, step by
    step with 2×2 closed forms."""
    from ekf.packing import pack_sym
    from railnav.navigation.hypothesis_step import common_continuous_log_likelihoods
    K, N = 3, 6
    innov = [rng.normal(size=(N, 2)) for _ in range(K)]
    A = rng.normal(size=(K, N, 2, 2))
    S = A @ A.swapaxes(-1, -2) + 0.5 * np.eye(2)
    got = common_continuous_log_likelihoods(innov, [pack_sym(S[j]) for j in range(K)])
    expected = np.zeros(K)
    for k in range(N):
        det = S[:, k, 0, 0] * S[:, k, 1, 1] - S[:, k, 0, 1] * S[:, k, 1, 0]
        (a, b), (_, d) = S[int(np.argmax(det)), k]
        for j in range(K):
            x, y = innov[j][k]
            expected[j] -= 0.5 * (d * x * x - 2 * b * x * y + a * y * y) / (a * d - b * b)
    np.testing.assert_allclose(got, expected, rtol=RTOL_LOG_LIKELIHOOD)
