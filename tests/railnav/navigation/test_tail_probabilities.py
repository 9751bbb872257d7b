"""`railnav.navigation.tail_probabilities`: the scalar tails (through
``scipy.special.cython_special``) are the numbers of `scipy.special`'s ufuncs, to the bit,
and the array paths agree with them element by element."""
from __future__ import annotations

import numpy as np
import scipy.special as sp

from railnav.navigation.tail_probabilities import binom_sf, chi2_cdf, chi2_sf


def test_scalar_tails_are_the_ufuncs_numbers(rng):
    """Reference: `scipy.special`'s ufuncs called on the same arguments."""
    for _ in range(2000):
        dof = int(rng.integers(0, 30))
        value = float(rng.exponential(2.0 * max(dof, 1)))
        assert chi2_sf(value, dof) == (float(sp.chdtrc(dof, value)) if dof > 0 else 1.0)
        assert chi2_cdf(value, dof) == (float(sp.chdtr(dof, value)) if dof > 0 else 1.0)
        assert chi2_sf(np.float64(value), float(dof)) == chi2_sf(value, dof)
        k = int(rng.integers(-1, 12))
        n = int(rng.integers(max(k, 0), 40))
        p = float(rng.uniform(0.0, 0.5))
        assert binom_sf(k, n, p) == (1.0 if k <= 0 else float(sp.bdtrc(k - 1, n, p)))
    assert np.isnan(chi2_sf(float("nan"), 3))


def test_array_tails_agree_with_the_scalar_ones(rng):
    """Reference: the scalar path, element by element."""
    values = rng.exponential(5.0, 50)
    dofs = rng.integers(0, 10, 50)
    ks = rng.integers(-1, 8, 50)
    ns = ks.clip(0) + rng.integers(0, 20, 50)
    chi = chi2_sf(values, dofs)
    binom = binom_sf(ks, ns, 0.1)
    for i in range(50):
        assert chi[i] == chi2_sf(float(values[i]), int(dofs[i]))
        assert binom[i] == binom_sf(int(ks[i]), int(ns[i]), 0.1)
