"""ekf — the estimation engine, free of rail and GNSS knowledge.

Owns: the state layout object, continuous-discrete extended Kalman filtering of models
given as CasADi functions (RK4 propagation, per-sample continuous measurements whose
noise is correlated with the process noise, discrete updates of any dimension),
innovation statistics and chi-square gating, an RTS smoother, and multiple-model banks.
Imports nothing else of the project.
"""
from __future__ import annotations

from ekf.bank import BankStep, Hypothesis, ModelBank, merge_gaussians
from ekf.cd_filter import CdFilter, FilterConfig
from ekf.compiled import CompileOptions
from ekf.consistency import chi2_band, normalized_squares
from ekf.errors import FilterDivergedError, FilterError, ModelError
from ekf.gating import Gate, chi2_threshold
from ekf.history import FilterResult, SmootherData
from ekf.layout import StateLayout
from ekf.linear import LinearModel, predict_linear
from ekf.model import CdModel, MeasurementModel
from ekf.propagate import Propagator, StepOutputs
from ekf.series import Epoch, InputSeries
from ekf.smoother import SmoothedResult, rts_smooth
from ekf.step import StepData, StepOptions, build_step
from ekf.update import Observation, UpdateRecord, discrete_update, kalman_update

__all__ = [
    "BankStep", "CdFilter", "CdModel", "CompileOptions", "Epoch", "FilterConfig",
    "FilterDivergedError", "FilterError", "FilterResult", "Gate", "Hypothesis",
    "InputSeries", "LinearModel", "MeasurementModel", "ModelBank", "ModelError",
    "Observation", "Propagator", "SmoothedResult", "SmootherData", "StateLayout",
    "StepData", "StepOptions", "StepOutputs", "UpdateRecord", "build_step", "chi2_band",
    "chi2_threshold", "discrete_update", "kalman_update", "merge_gaussians",
    "normalized_squares", "predict_linear", "rts_smooth",
]
