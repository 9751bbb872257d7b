"""Helpers shared by the strapdown tests."""
from __future__ import annotations

import numpy as np
import pytest

#: Relative central-difference step.
FD_STEP = 1e-6


def _central_jacobian(fn, x):
    """Central-difference Jacobian of ``fn`` (array -> array) at ``x``, shape (m, n)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        step = FD_STEP * max(1.0, abs(x[i]))
        e = np.zeros_like(x)
        e[i] = step
        cols.append((np.asarray(fn(x + e)) - np.asarray(fn(x - e))).ravel() / (2 * step))
    return np.stack(cols, axis=-1)


@pytest.fixture
def central_jacobian():
    """``central_jacobian(fn, x)``: the independent reference for CasADi Jacobians."""
    return _central_jacobian
