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
symbolic per-step function and its equations), ``compiled`` / ``propagate`` (running it;
``library_cache``: the compiled libraries on disk, ``$RAILNAV_CACHE_DIR``; ``stacked`` /
``lanes``: a bank's members propagated together, the step written for vector lanes, one
member per lane, all members in one compiled call),
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

The names are imported on first use (PEP 562), so ``import ekf`` (and ``ekf.errors``)
stays cheap: it imports neither CasADi nor SciPy.
"""
from __future__ import annotations

import importlib

#: Public name -> the module that owns it.
_EXPORTS = {
    "BankStep": "bank", "CdFilter": "cd_filter", "CdModel": "model",
    "CompileOptions": "compiled", "Epoch": "series", "EpochRows": "series",
    "FilterConfig": "cd_filter", "FilterDivergedError": "errors", "FilterError": "errors",
    "FilterResult": "history", "Gate": "gating", "Hypothesis": "bank",
    "InputSeries": "series", "LinearModel": "linear", "MeasurementModel": "model",
    "ModelBank": "bank", "ModelError": "errors", "Observation": "update",
    "Propagator": "propagate", "SmoothedResult": "smoother", "SmootherData": "history",
    "StateLayout": "layout", "StepData": "step", "StepOptions": "step",
    "StepOutputs": "propagate", "UpdateRecord": "update", "build_step": "step",
    "chi2_band": "consistency", "chi2_threshold": "gating", "common_offset": "outliers",
    "correlated_step": "correlated", "discrete_update": "update",
    "fault_probability": "outliers", "fault_threshold": "outliers", "imm_mixing": "bank",
    "imm_starts": "bank",
    "kalman_update": "update", "log_predict": "bank", "logsumexp": "bank", "merge_gaussians": "bank",
    "merge_gaussians_many": "bank",
    "normalized_squares": "consistency", "predict_linear": "linear",
    "rts_smooth": "smoother", "switching_update": "bank", "uniform_switching": "bank",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'ekf' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"ekf.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
