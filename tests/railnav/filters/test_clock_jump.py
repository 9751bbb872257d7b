"""`railnav.filters.clock_jump.find_clock_jump` on its own, against the closed form of the
common offset: the generalized least-squares mean ``â = 1ᵀS⁻¹ν / 1ᵀS⁻¹1`` of the tested
rows (computed here with `numpy.linalg.solve`, not `ekf.outliers.common_offset`)."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.gating import chi2_threshold
from railnav.filters.clock_jump import MIN_JUMP_ROWS, NIS_BOUND_MARGIN, find_clock_jump
from railnav.filters.fault_config import FaultDetectionConfig

CONFIG = FaultDetectionConfig()
#: Six pseudoranges with correlated innovations (a shared prior), m².
_A = np.array([[1.0, 0.3, 0.2, 0.1, 0.4, 0.2], [0.5, 1.0, 0.1, 0.3, 0.2, 0.6]]).T
S = _A @ _A.T + 9.0 * np.eye(6)
KIND = np.array(["pseudorange"] * 6, dtype=object)


def _gls_offset(nu, S):
    ones = np.ones(nu.size)
    w = np.linalg.solve(S, ones)
    return float(w @ nu / (w @ ones))


def test_the_admitted_rows_declare_the_jump_a_faulty_excluded_row_would_spoil():
    """500 m on every row plus 300 m more on row 0: with row 0 tested the residual is
    inconsistent (no jump); without it (its channel excluded) the jump is the GLS offset of
    rows 1-5 and its variance ``(3 â)²`` (`FaultDetectionConfig.clock_jump_sigma_factor`)."""
    nu = np.full(6, 500.0) + np.array([0.3, -1.2, 2.0, 0.4, -0.8, 1.1])
    nu[0] += 300.0
    assert find_clock_jump(CONFIG, KIND, nu, S) is None
    admitted = np.arange(6) != 0
    offset, variance = find_clock_jump(CONFIG, KIND, nu, S, admitted)
    expected = _gls_offset(nu[admitted], S[np.ix_(admitted, admitted)])
    assert offset == pytest.approx(expected, rel=1e-12)
    assert variance == pytest.approx((CONFIG.clock_jump_sigma_factor * expected) ** 2,
                                     rel=1e-12)


def test_too_few_pseudoranges_declare_nothing():
    """A 1-km offset on MIN_JUMP_ROWS - 1 pseudoranges (the other rows range rates): not
    tested, one faulty satellite and a jump cannot be told apart."""
    kind = KIND.copy()
    kind[MIN_JUMP_ROWS - 1:] = "range_rate"
    nu = np.where(kind == "pseudorange", 1000.0, 0.1)
    assert find_clock_jump(CONFIG, kind, nu, S) is None
    kind[MIN_JUMP_ROWS - 1] = "pseudorange"                 # one more: a jump
    nu = np.where(kind == "pseudorange", 1000.0, 0.1)
    assert find_clock_jump(CONFIG, kind, nu, S) is not None


def test_the_rows_variances_pass_small_epochs_with_the_same_decision():
    """``S = H P Hᵀ + diag(n)``: 400 random epochs (7 pseudoranges, 5 range rates, some
    with a common offset up to 40 m): the GLS offset's NIS ``â² · 1ᵀS⁻¹1`` (computed here)
    never exceeds ``Σ ν²/n``, and `find_clock_jump` given `n` declares exactly what it
    declares without, with the same numbers; most epochs lie under the bound's margin."""
    rng = np.random.default_rng(7)
    kind = np.array(["pseudorange"] * 7 + ["range_rate"] * 5, dtype=object)
    members = kind == "pseudorange"
    threshold = chi2_threshold(1.0 - CONFIG.clock_jump_false_alarm, 1)
    declared = under = 0
    for _ in range(400):
        noise = np.where(members, 9.0, 0.01) * rng.uniform(0.5, 2.0, 12)
        # a prior's part of each row's variance up to ~its noise's (a filter under way)
        H = np.sqrt(noise)[:, None] * rng.normal(size=(12, 7)) / np.sqrt(7.0)
        L = rng.normal(size=(7, 7)) / np.sqrt(7.0) * rng.uniform(0.05, 1.0)
        S = H @ (L @ L.T) @ H.T + np.diag(noise)
        nu = np.linalg.cholesky(S) @ rng.normal(size=12)
        nu[members] += rng.choice([0.0, 0.0, 0.0, rng.uniform(0.0, 40.0)])
        d = members.astype(float)                    # the offset's direction in all rows
        w = np.linalg.solve(S, d)
        glr = (w @ nu) ** 2 / (w @ d)
        assert glr <= float(nu @ (nu / noise)) * (1 + 1e-12)
        under += float(nu @ (nu / noise)) < NIS_BOUND_MARGIN * threshold
        found = find_clock_jump(CONFIG, kind, nu, S, noise=noise)
        assert found == find_clock_jump(CONFIG, kind, nu, S)
        declared += found is not None
    assert declared > 20 and under > 100
