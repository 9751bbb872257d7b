"""The closed-form weighted least squares of 1-3 unknowns (`gnss_obs.wls_solvers`) against
the general path (Cholesky of the normal matrix, `CholeskyWls`) and against an independent
second method: NumPy's `lstsq` (an SVD of the whitened design, no normal matrix), on random
well- and ill-conditioned problems; the singular cases raise as the Cholesky path does."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from gnss_obs.raim import fault_detection_exclusion, huber_wls, wls_step
from gnss_obs.wls_solvers import (CholeskyWls, ClosedFormWls, closed_form_solve,
                                  wls_problem)

EPS = np.finfo(float).eps


def _problem(rng, k: int, n: int, condition: float):
    """A track-like design: an ``s`` column of unit-vector components, then clock columns
    of ones (one per system, rows split between them); `condition` > 1 bends the last
    column towards the first (κ of the whitened normal matrix ~ condition)."""
    H = np.empty((n, k))
    H[:, 0] = rng.uniform(-1.0, 1.0, n)
    for c in range(1, k):
        H[:, c] = (np.arange(n) % (k - 1) == c - 1) if k > 2 else 1.0
    if condition > 1.0:
        H[:, -1] = H[:, 0] + rng.normal(size=n) / np.sqrt(condition)
    sigma = rng.uniform(0.5, 5.0, n)
    z = H @ rng.normal(scale=10.0, size=k) + rng.normal(size=n) * sigma
    return H, z, sigma


def _lstsq(H, z, sigma, weight=None):
    """Second method: SVD least squares of the whitened system, and its covariance from the
    SVD (``V diag(1/s²) Vᵀ``)."""
    w = np.ones(z.size) if weight is None else weight
    A, y = H * (np.sqrt(w) / sigma)[:, None], z * np.sqrt(w) / sigma
    dx = np.linalg.lstsq(A, y, rcond=None)[0]
    _, s, Vt = np.linalg.svd(A, full_matrices=False)
    return dx, (Vt.T / s ** 2) @ Vt, np.linalg.cond(A.T @ A)


@pytest.mark.parametrize("k, condition", [(1, 1.0)] + [(k, c) for k in (2, 3)
                                                      for c in (1.0, 1e4, 1e8, 1e10)])
def test_closed_form_equals_cholesky_and_svd(rng, k, condition):
    """dx and the covariance at random weights agree with both methods within the
    normal equations' forward error bound, ``c κ(AᵀA) ε`` (relative; c = 100); the
    whitened residuals, the leverages and the test statistic likewise."""
    for _ in range(40):
        n = int(rng.integers(k + 1, 13))
        H, z, sigma = _problem(rng, k, n, condition)
        weight = rng.uniform(0.05, 1.0, n)
        cf, ch = ClosedFormWls(H, z, sigma), CholeskyWls(H, z, sigma)
        (s1, core1), (s2, core2) = cf.solution(weight), ch.solution(weight)
        dx_svd, cov_svd, kappa = _lstsq(H, z, sigma, weight)
        tol = 100.0 * kappa * EPS
        for dx, cov in ((core1[3], core1[1]), (core2[3], core2[1])):
            assert np.linalg.norm(dx - dx_svd) <= tol * np.linalg.norm(dx_svd)
            assert np.linalg.norm(cov - cov_svd) <= tol * np.linalg.norm(cov_svd)
        np.testing.assert_allclose(s1, s2, rtol=4 * EPS)
        # whitened residuals: |Δr| ≤ |A Δdx|, the same bound on the whitened y's scale
        scale = np.linalg.norm(z / s2)
        assert np.linalg.norm(core1[4] - core2[4]) <= tol * scale
        lev1, lev2 = (np.einsum("ij,ji->i", c[0], c[2]) for c in (core1, core2))
        np.testing.assert_allclose(lev1, lev2, rtol=0, atol=tol * k)


def test_closed_form_solve_is_the_inverse(rng):
    """`closed_form_solve` against `numpy.linalg.inv` on random SPD matrices, and its
    solution against `numpy.linalg.solve` (well-conditioned: to 1e-12)."""
    for k in (1, 2, 3):
        for _ in range(50):
            M = rng.normal(size=(k + 4, k + 1))
            gram = M.T @ M
            inverse, dx = closed_form_solve(gram.ravel().tolist(), k)
            N, b = gram[:k, :k], gram[:k, k]
            np.testing.assert_allclose(inverse, np.linalg.inv(N), rtol=1e-10,
                                       atol=1e-12 * np.abs(np.linalg.inv(N)).max())
            np.testing.assert_allclose(dx, np.linalg.solve(N, b), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("normal", [
    [[0.0]], [[-1.0]],                                    # 1x1 not positive
    [[1.0, 2.0], [2.0, 4.0]],                             # singular
    [[-1.0, 0.0], [0.0, 1.0]],                            # first minor < 0
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -2.0]],  # det < 0
    [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, -1.0]],  # det > 0, 2nd minor < 0
])
def test_not_positive_definite_raises_as_cholesky(normal):
    """Sylvester's criterion (every leading minor > 0) is Cholesky's test: both raise
    `LinAlgError` (`scipy.linalg.cho_factor` the reference)."""
    k = len(normal)
    gram = np.zeros((k + 1, k + 1))
    gram[:k, :k] = normal
    with pytest.raises(np.linalg.LinAlgError):
        linalg.cho_factor(np.array(normal))
    with pytest.raises(np.linalg.LinAlgError):
        closed_form_solve(gram.ravel().tolist(), k)


def test_singular_and_non_finite_problems_raise_as_the_general_path():
    """Collinear columns, fewer rows than unknowns: `LinAlgError`; a NaN in ``H``:
    `ValueError` (as `CholeskyWls`); an overflowing determinant with finite entries is
    solved (by Cholesky)."""
    H = np.hstack([np.ones((5, 1)), np.ones((5, 1))])
    for cls in (ClosedFormWls, CholeskyWls):
        with pytest.raises(np.linalg.LinAlgError):
            cls(H, np.arange(5.0), np.ones(5)).residuals(None)
    with pytest.raises(np.linalg.LinAlgError):
        wls_step(np.ones((1, 2)), np.ones(1), np.ones(1))
    bad = np.ones((4, 2))
    bad[1, 0] = np.nan
    for cls in (ClosedFormWls, CholeskyWls):
        with pytest.raises(ValueError):
            cls(bad, np.arange(4.0), np.ones(4)).residuals(None)
    inverse, dx = closed_form_solve([1e160, 0.0, 2e160, 0.0, 1e160, 3e160, 0.0, 0.0, 0.0], 2)
    np.testing.assert_allclose(inverse, [[1e-160, 0.0], [0.0, 1e-160]], rtol=1e-15)
    np.testing.assert_allclose(dx, [2.0, 3.0], rtol=1e-15)


def test_huber_and_exclusion_in_closed_form_equal_the_general_path(rng, monkeypatch):
    """`huber_wls` and `fault_detection_exclusion` on 1-3 unknowns (closed form) against
    the same IRLS and exclusion with every solve by Cholesky (`CholeskyWls` forced):
    the same exclusions and iterations, dx and σ equal to ~1e-12 relative. (Each clock
    column has at least 4 rows: a system of 2 rows has two standardized residuals equal
    and opposite, and which of them is excluded is round-off's choice in either path.)"""
    import gnss_obs.raim as raim
    for trial in range(300):
        k = 1 + trial % 3
        n = int(rng.integers(4 * max(k - 1, 1), 14))
        H, z, sigma = _problem(rng, k, n, 1.0)
        if trial % 2:
            z[rng.integers(n)] += rng.choice([3.0, 50.0]) * sigma.max()   # outlier
        assert isinstance(wls_problem(H, z, sigma), ClosedFormWls)
        closed = fault_detection_exclusion(H, z, sigma, p_false_alarm=1e-3,
                                           max_exclusions=2, huber_k=1.5)
        h_closed, sigma_closed = huber_wls(H, z, sigma, huber_k=1.5)
        with monkeypatch.context() as patch:
            patch.setattr(raim, "wls_problem", CholeskyWls)
            general = fault_detection_exclusion(H, z, sigma, p_false_alarm=1e-3,
                                                max_exclusions=2, huber_k=1.5)
            h_general, sigma_general = huber_wls(H, z, sigma, huber_k=1.5)
        assert np.array_equal(closed.kept, general.kept)
        assert closed.raim_ok == general.raim_ok
        for a, b in ((closed.step, general.step), (h_closed, h_general)):
            scale = np.sqrt(np.diag(b.cov))
            np.testing.assert_allclose(a.dx / scale, b.dx / scale, rtol=0, atol=1e-11)
            np.testing.assert_allclose(a.cov, b.cov, rtol=1e-11)
            np.testing.assert_allclose(a.test_statistic, b.test_statistic, rtol=1e-11)
        np.testing.assert_allclose(sigma_closed, sigma_general, rtol=1e-11)


def test_dispatch_by_number_of_unknowns(rng):
    """1-3 unknowns in closed form, 4 and more (the single-point solution) by Cholesky."""
    for k, cls in ((1, ClosedFormWls), (3, ClosedFormWls), (4, CholeskyWls),
                   (5, CholeskyWls)):
        H = rng.normal(size=(8, k))
        assert type(wls_problem(H, np.zeros(8), np.ones(8))) is cls
