"""The default tolerances of `trackmodel.fit.fit_track`, each written once here.

In a module that imports nothing, so that the ``railnav track fit`` parser can show them
without importing the fitter (SciPy, pandas). `trackmodel.fit` re-exports them.
"""
from __future__ import annotations

__all__ = ["DEFAULT_TOL_M", "DEFAULT_VTOL_M"]

#: Largest horizontal deviation of a surveyed point from the fitted track, m.
DEFAULT_TOL_M = 0.5
#: Largest height deviation the fitted vertical profile aims for, m.
DEFAULT_VTOL_M = 1.0
