"""An epoch's satellite terms at a receiver guess in compiled C (issue 15).

`gnss_obs.guess_terms.satellite_terms` (flight time, Sagnac rotation, look angles, slant
troposphere and ionosphere, σ of one satellite at one guess) is written with NumPy ufuncs
and operators only; here the same function is called on CasADi symbols, and the
expression compiled to a C loop over guesses and an epoch's satellites
(`ekf.compiled_each.CompiledEach`, cached on disk under the hash of the expression). A
filter's epoch (a bank's K guesses) is then one ctypes call instead of ~60 NumPy calls
on arrays of ~10 satellites.

The numbers are those of the NumPy evaluation (`gnss_obs.guess_terms.evaluate_numpy`) to
the last bits only: C's libm and CasADi's own expressions (``x³`` as ``x·x²``, ``mod`` as
``x - y floor(x/y)``) against NumPy's SIMD loops (`tests/railnav/filters/
test_guess_kernel.py` bounds the difference). Without a C compiler, `compiled_evaluator`
gives None and the NumPy evaluation is used.
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ekf.compiled import compiler_available
from ekf.compiled_each import CompiledEach
from gnss_obs.guess_terms import (
    RECEIVER_TERMS,
    SATELLITE_COLUMNS,
    satellite_terms,
)
from gnss_obs.measurements import MeasurementConfig

__all__ = ["compiled_evaluator", "CompiledTerms", "terms_function"]


def terms_function(config: MeasurementConfig, with_klobuchar: bool) -> ca.Function:
    """``(rx, sat) -> outputs``: `satellite_terms` of one satellite at one guess as a
    CasADi function (the `gnss_obs.guess_terms.OUTPUTS`)."""
    rx = ca.SX.sym("rx", RECEIVER_TERMS)
    sat = ca.SX.sym("sat", SATELLITE_COLUMNS)
    mode = ca.GlobalOptions.getNumpyMode()
    ca.GlobalOptions.setNumpyMode(-1)     # NumPy ufuncs on symbols give symbols, silently
    try:
        out = satellite_terms([rx[i] for i in range(RECEIVER_TERMS)],
                              [sat[i] for i in range(SATELLITE_COLUMNS)], config,
                              with_klobuchar, where=ca.if_else)
    finally:
        ca.GlobalOptions.setNumpyMode(mode)
    return ca.Function("gnss_guess_terms", [rx, sat],
                       [ca.vertcat(*a) if isinstance(a, tuple) else a for a in out])


@functools.lru_cache(maxsize=16)
def compiled_evaluator(config: MeasurementConfig) -> "CompiledTerms | None":
    """The `CompiledTerms` of `config` (one a process), or None without a C compiler."""
    return CompiledTerms(config) if compiler_available() else None


class CompiledTerms:
    """``evaluate(rx, sat, config, with_klobuchar)`` for `gnss_obs.epoch.prepare_epochs`
    running the compiled `terms_function` of its configuration: one C call for all guesses
    (K rows `rx`) and satellites (`sat`, C-contiguous floats, as
    `gnss_obs.guess_terms.satellite_columns` gives them). The libraries are loaded at the
    first call of each Klobuchar flag; a pickled copy loads its own."""

    def __init__(self, config: MeasurementConfig) -> None:
        self.config = config
        self._runs: dict = {}

    def __call__(self, rx: np.ndarray, sat: np.ndarray, config: MeasurementConfig,
                 with_klobuchar: bool) -> list[np.ndarray]:
        run = self._runs.get(with_klobuchar)
        if run is None:
            run = self._runs[with_klobuchar] = CompiledEach(
                terms_function(self.config, with_klobuchar)).run
        return run(rx, sat)

    def __getstate__(self) -> dict:
        return {"config": self.config, "_runs": {}}
