"""strapdown — inertial navigation physics.

Owns: normal gravity and Earth/transport rates, body/navigation frames and Euler
kinematics (DCM body->ENU from yaw, pitch, roll and the Euler-rate matrix derived from
it), the full 9-state and the track-constrained (reduced) mechanizations as CasADi
functions with their Jacobians, fixed-step RK4 over IMU samples, and IMU error models
with grade presets. Uses the Earth model of `trackmodel.earth` and the state layout of
`ekf.layout` (`StateLayout`): states, inputs and track parameters are addressed by name.

The public names, importable from the package itself::

    from strapdown import ImuErrors, IMU_GRADES, build_reduced_model

==========================  =======================================================
topic                       names (owning module)
==========================  =======================================================
IMU samples                 `Imu`, `read_imu_csv`, `IMU_COLUMNS` (``imu``)
recorded IMU logs           `ImuSpec`, `read_imu_spec`, `imu_spec_from_dict`
                            (``imu_spec``), `read_imu_log`, `ImuLog` (``imu_log``),
                            `check_imu_plausible` (``imu_checks``)
IMU errors                  `ImuErrors`, `TriadErrors`, `IMU_GRADES` (the grade
                            presets), `imu_grade`, `apply_imu_errors`,
                            `STANDARD_GRAVITY_MPS2` (``imu_errors``)
errors                      `StrapdownError`, `ImuInputError` (``errors``)
full model                  `build_full_model`, `FullModel`, `FULL_STATE_NAMES`
                            (``mechanization``)
reduced model               `build_reduced_model`, `ReducedModel`,
                            `REDUCED_STATE_NAMES`, `TRACK_PARAMETER_NAMES`,
                            `track_parameters`, `cross_track_basis` (``reduced``)
shared by the models        `SensorBiasStates`, `INPUT_NAMES`, `BIAS_STATE_NAMES`
                            (``kinematics``)
integration                 `integrate` (``rk4``), `integrate_on_track`
                            (``track_integration``)
physics                     `g_n` (``gravity``), `C_b_n` (``euler``),
                            `radii_of_curvature`, `omega_ie_n`, `omega_en_n`
                            (``frames``), `batch_call` (``backend``)
==========================  =======================================================

The names are imported on first use (PEP 562), so ``import strapdown`` stays cheap: it
imports neither CasADi nor SciPy.
"""
from __future__ import annotations

import importlib

#: Public name -> the module that owns it.
_EXPORTS = {
    "Imu": "imu", "read_imu_csv": "imu", "IMU_COLUMNS": "imu",
    "ImuSpec": "imu_spec", "read_imu_spec": "imu_spec", "imu_spec_from_dict": "imu_spec",
    "read_imu_log": "imu_log", "ImuLog": "imu_log", "check_imu_plausible": "imu_checks",
    "ImuErrors": "imu_errors", "TriadErrors": "imu_errors", "IMU_GRADES": "imu_errors",
    "imu_grade": "imu_errors", "apply_imu_errors": "imu_errors",
    "STANDARD_GRAVITY_MPS2": "imu_errors",
    "StrapdownError": "errors", "ImuInputError": "errors",
    "build_full_model": "mechanization", "FullModel": "mechanization",
    "FULL_STATE_NAMES": "mechanization",
    "build_reduced_model": "reduced", "ReducedModel": "reduced",
    "REDUCED_STATE_NAMES": "reduced", "TRACK_PARAMETER_NAMES": "reduced",
    "track_parameters": "reduced", "cross_track_basis": "reduced",
    "SensorBiasStates": "kinematics", "INPUT_NAMES": "kinematics",
    "BIAS_STATE_NAMES": "kinematics",
    "integrate": "rk4", "integrate_on_track": "track_integration",
    "g_n": "gravity", "C_b_n": "euler", "radii_of_curvature": "frames",
    "omega_ie_n": "frames", "omega_en_n": "frames", "batch_call": "backend",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'strapdown' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"strapdown.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
