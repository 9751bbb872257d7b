"""The start's variance factors from the first fixes' scatter
(`railnav.navigation.start_scatter`) and the noise scale's seed
(`railnav.filters.noise_scale.NoiseScale.seed`).

References: the weighted mean's χ² in closed form; a generalized least-squares fit with the
full block-diagonal covariance inverted densely (a second method); the binomial band of
the false-inflation rate and the χ² distribution of the factor (SciPy).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom, chi2

from railnav.filters.noise_scale import NoiseScale, NoiseScaleConfig
from railnav.navigation.start_scatter import polynomial_chi2, scatter_factors
from trackmodel.earth import C_n_e, geodetic_to_ecef

RNG_SEED = 20261207


def test_degree_zero_is_the_weighted_mean():
    rng = np.random.default_rng(RNG_SEED)
    t = np.arange(8.0)
    sigma = rng.uniform(0.5, 3.0, 8)
    y = rng.normal(2.0, sigma)
    mean = np.sum(y / sigma**2) / np.sum(1 / sigma**2)
    expected = float(np.sum(((y - mean) / sigma) ** 2))
    got, dof = polynomial_chi2(t, y[:, None], (sigma**2)[:, None, None], degree=0)
    assert dof == 7
    assert got == pytest.approx(expected, rel=1e-10)


def test_two_components_correlated_against_dense_gls():
    """χ² of a cubic in each of two correlated components, against GLS with the dense
    (2N × 2N) inverse covariance."""
    rng = np.random.default_rng(RNG_SEED + 1)
    n, degree = 10, 3
    t = np.sort(rng.uniform(0.0, 12.0, n))
    A = rng.normal(size=(n, 2, 2))
    cov = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(2)
    values = rng.normal(size=(n, 2)) * 3.0 + t[:, None] ** 2
    # dense GLS: y (component-major per epoch), X block-wise
    basis = np.vander(t, degree + 1, increasing=True)
    X = np.zeros((2 * n, 2 * (degree + 1)))
    X[0::2, : degree + 1] = basis
    X[1::2, degree + 1:] = basis
    W = np.zeros((2 * n, 2 * n))
    for k in range(n):
        W[2 * k:2 * k + 2, 2 * k:2 * k + 2] = np.linalg.inv(cov[k])
    y = values.reshape(-1)
    beta = np.linalg.solve(X.T @ W @ X, X.T @ W @ y)
    r = y - X @ beta
    got, dof = polynomial_chi2(t, values, cov, degree=degree)
    assert dof == 2 * (n - degree - 1)
    assert got == pytest.approx(float(r @ W @ r), rel=1e-8)


def _fixes(rng, n: int, *, ratio: float, moving: bool = True):
    """`n` fixes at 1 Hz of a receiver accelerating along a straight line (a path a cubic
    and a quadratic fit exactly; `moving` False: standing), errors drawn at `ratio` times
    the covariances given."""
    t = np.arange(float(n))
    lat, lon = np.radians(48.1), np.radians(11.5)
    r0 = geodetic_to_ecef(lat, lon, 520.0)
    C = C_n_e(lat, lon)
    heading = np.array([0.6, 0.8, 0.0])
    along = (6.0 * t + 0.25 * t**2) * moving
    cov = np.diag([1.5, 2.0, 6.0]) ** 2
    cov_v = np.diag([0.08, 0.1, 0.2]) ** 2
    e = rng.multivariate_normal(np.zeros(3), cov * ratio, n)
    ev = rng.multivariate_normal(np.zeros(3), cov_v * ratio, n)
    r_e = r0 + (along[:, None] * heading + e) @ C.T
    v_e = ((6.0 + 0.5 * t)[:, None] * moving * heading + ev) @ C.T
    return t, r_e, v_e, np.repeat(cov[None], n, 0), np.repeat(cov_v[None], n, 0)


@pytest.mark.parametrize("moving, dof_velocity", [(True, 7), (False, 14)])
def test_told_right_the_factor_is_one_but_at_the_false_rate(moving, dof_velocity):
    """σ right: the factors are exactly 1 but in a share `p_false` of the starts
    (binomial 99.9 % band), and the χ² of the fits are χ²_dof (mean within 4 standard
    errors). Moving, the velocity fit takes the speed (10 − 3 dof); standing, the two
    horizontal components (2 (10 − 3))."""
    rng = np.random.default_rng(RNG_SEED + 2)
    runs, p_false = 2000, 0.05
    found = [scatter_factors(*_fixes(rng, 10, ratio=1.0, moving=moving), p_false=p_false)
             for _ in range(runs)]
    for name in ("position", "velocity"):
        inflated = sum(getattr(f, name) != 1.0 for f in found)
        lo, hi = binom.ppf([0.0005, 0.9995], runs, p_false)
        assert lo <= inflated <= hi, (name, inflated)
        dof = getattr(found[0], f"dof_{name}")
        for f in found:          # inflated exactly when beyond the test's quantile
            beyond = getattr(f, f"chi2_{name}") > chi2.isf(p_false, dof)
            assert getattr(f, name) == (getattr(f, f"chi2_{name}") / dof if beyond else 1.0)
        values = np.array([getattr(f, f"chi2_{name}") for f in found])
        assert abs(values.mean() - dof) < 4 * np.sqrt(2 * dof / runs), name
    assert (found[0].dof_position, found[0].dof_velocity) == (12, dof_velocity)


def test_overconfident_fixes_get_their_ratio():
    """Errors 25× the covariances' variance (moving at 6 m/s, beyond 5 of the σ of its
    speed the scatter of its components gives: the speeds are fitted): the share of starts inflated at the default
    significance is χ²'s (``P(25 χ²_dof > χ²_dof(1 − 1e-3))``, binomial 99.9 % band), by
    χ²/dof, whose mean over the runs is 25 (within 4 standard errors of χ²_dof's)."""
    rng = np.random.default_rng(RNG_SEED + 3)
    runs, ratio = 400, 25.0
    found = [scatter_factors(*_fixes(rng, 10, ratio=ratio)) for _ in range(runs)]
    assert {f.dof_velocity for f in found} == {7}
    for name, dof in (("position", 12), ("velocity", 7)):
        factor = np.array([getattr(f, name) for f in found])
        chi = np.array([getattr(f, f"chi2_{name}") for f in found])
        beyond = chi > chi2.isf(1e-3, dof)
        p = chi2.sf(chi2.isf(1e-3, dof) / ratio, dof)
        lo, hi = binom.ppf([0.0005, 0.9995], runs, p)
        assert lo <= beyond.sum() <= hi, (name, beyond.sum(), p * runs)
        np.testing.assert_allclose(factor[beyond], chi[beyond] / dof, rtol=1e-12)
        assert np.all(factor[~beyond] == 1.0)
        assert abs(chi.mean() / dof - ratio) < 4 * ratio * np.sqrt(2.0 / dof / runs), name


def test_too_few_fixes_leave_the_start_alone():
    rng = np.random.default_rng(RNG_SEED + 4)
    found = scatter_factors(*_fixes(rng, 4, ratio=100.0))
    assert (found.position, found.dof_position) == (1.0, 0)
    assert found.dof_velocity == 1                                # 4 speeds, 3 coefficients


def test_noise_scale_seed_holds_for_one_window():
    """A seed is in effect at once, as a floor for half the window, falling linearly to
    1 when the window has turned over (rows told right then give exactly 1); without a
    configuration it does nothing; it is capped at the largest factor."""
    cfg = NoiseScaleConfig(window_epochs=5)
    scale = NoiseScale(cfg)
    scale.seed({"pseudorange": 9.0, "range_rate": 0.5})
    assert scale.variance_factor == {"pseudorange": 9.0, "range_rate": 1.0}
    rng = np.random.default_rng(RNG_SEED + 5)
    seen = []
    for _ in range(6):
        b = np.full(8, 4.0)
        rows = {k: (rng.normal(0.0, 2.0, 8), np.zeros(8), b)
                for k in ("pseudorange", "range_rate")}
        scale.add(rows)
        seen.append(scale.variance_factor["pseudorange"])
    # the floor 1 + 8 · min(1, (5 − n) / 2.5) after n epochs
    assert seen == pytest.approx([9.0, 9.0, 7.4, 4.2, 1.0, 1.0], rel=1e-12)
    off = NoiseScale(None)
    off.seed({"pseudorange": 9.0})
    assert off.variance_factor["pseudorange"] == 1.0
    capped = NoiseScale(NoiseScaleConfig(max_sigma_factor=2.0))
    capped.seed({"range_rate": 100.0})
    assert capped.variance_factor["range_rate"] == 4.0
