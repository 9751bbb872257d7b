"""ekf — the estimation engine, free of rail and GNSS knowledge.

Owns: the state layout object, continuous-discrete extended Kalman filtering of models
given as CasADi functions (RK4 propagation, per-sample continuous measurements whose
noise is correlated with the process noise, discrete updates of any dimension),
innovation statistics and chi-square gating, an RTS smoother, and multiple-model banks.
Imports nothing else of the project (NumPy, SciPy, CasADi; pandas only in ``to_frame``).

Typical use::

    model = CdModel.from_expressions(layout, x, u, p, xdot, h_c=h_c)   # G, D default
    filt = CdFilter(model, FilterConfig(gate=Gate(0.999, scope="rows"), smoothing=True))
    res = filt.run(InputSeries(t=t, u=imu, q_c=q_c), epochs, x0=x0, P0=P0)
    smooth = rts_smooth(res.smoother, res.x_final, res.P_final)

Modules: ``layout`` (StateLayout), ``model`` (CdModel, MeasurementModel), ``step`` (the
symbolic per-step function and its equations), ``compiled`` / ``propagate`` (running it),
``update`` / ``gating`` (discrete updates), ``series`` / ``cd_filter`` / ``history`` (the
driver), ``smoother``, ``consistency``, ``linear`` / ``correlated`` / ``bank`` (linear KF,
a linear step with measurement noise correlated with the process noise, multiple-model
banks), ``outliers`` (the fault hypothesis of a row, the common-offset test). The same
step in plain NumPy and a small example model, which the tests and the benchmark check
the engine against, are test support, not part of the package:
``tests/support/ekf_reference.py`` and ``tests/support/ekf_examples.py``.

Two properties to know when building a model on it:

* Noise model of the inputs: with ``StepOptions(input_hold="zoh")`` an input sample is
  the mean of the input over its step, and white sample noise of variance ``q_c/dt`` is
  exactly the model's noise. With ``"linear"`` (default) the step uses two samples, so the
  noise of a sample enters two steps and the filter's noise model is approximate.
* A continuous measurement whose Jacobian depends on a noisy input (e.g. ``v·ω``) is
  biased by errors in variables by ``ω²/(ω² + σ_ω²)`` per sample (``σ_ω`` = per-sample
  input noise): negligible when the per-sample noise is small against the signal.
"""
from __future__ import annotations

from ekf.bank import (BankStep, Hypothesis, ModelBank, imm_starts, merge_gaussians,
                      switching_update, uniform_switching)
from ekf.cd_filter import CdFilter, FilterConfig
from ekf.compiled import CompileOptions
from ekf.consistency import chi2_band, normalized_squares
from ekf.correlated import correlated_step
from ekf.errors import FilterDivergedError, FilterError, ModelError
from ekf.gating import Gate, chi2_threshold
from ekf.history import FilterResult, SmootherData
from ekf.layout import StateLayout
from ekf.linear import LinearModel, predict_linear
from ekf.model import CdModel, MeasurementModel
from ekf.propagate import Propagator, StepOutputs
from ekf.outliers import common_offset, fault_probability, fault_threshold
from ekf.series import Epoch, EpochRows, InputSeries
from ekf.smoother import SmoothedResult, rts_smooth
from ekf.step import StepData, StepOptions, build_step
from ekf.update import Observation, UpdateRecord, discrete_update, kalman_update

__all__ = [
    "BankStep", "CdFilter", "CdModel", "CompileOptions", "Epoch", "EpochRows", "FilterConfig",
    "FilterDivergedError", "FilterError", "FilterResult", "Gate", "Hypothesis",
    "InputSeries", "LinearModel", "MeasurementModel", "ModelBank", "ModelError",
    "Observation", "Propagator", "SmoothedResult", "SmootherData", "StateLayout",
    "StepData", "StepOptions", "StepOutputs", "UpdateRecord", "build_step", "chi2_band",
    "chi2_threshold", "common_offset", "correlated_step", "discrete_update",
    "fault_probability", "fault_threshold", "imm_starts", "kalman_update", "merge_gaussians",
    "normalized_squares", "predict_linear", "rts_smooth", "switching_update",
    "uniform_switching",
]
