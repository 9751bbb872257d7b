"""Pseudorange and range-rate measurement models as CasADi functions, with Jacobians.

The one implementation of the GNSS observation equations (ARCHITECTURE.md, GNSS), used by
the SPP (`gnss_obs.spp`) and the navigator. With the satellite data of a `PreparedEpoch`
(`gnss_obs.epoch`: satellite at transmission in ECEF of reception, clock for the signal,
delays):

``ρ  = |sat_pos_e - r_e| + b_m - sat_clock_m + delays_m``

``ρ̇ = e · (sat_vel_e - v_e) + d_mps - sat_clock_drift_mps``, ``e = (sat_pos_e - r_e)/|…|``

Receiver clock states are in metres (``b_m = c δt_r``) and metres per second
(``d_mps = c dδt_r/dt``). With several systems each satellite's ``b_m`` is the reference
clock plus its system's inter-system bias: `system_bias_matrix` maps the clock states to
satellites (``b_sat = S @ clock_states``), and the chain rule gives the Jacobian w.r.t. the
clock states as ``H_b * S``. A navigator composing ``r_e = r_e(s)`` uses ``H_r @ dr_e/ds``.

`build_measurement_model` builds the single-satellite functions once (cached);
`mapped_measurement_model(n)` maps them over n satellites (`casadi.Function.map`, the
receiver inputs broadcast). `predict_pseudorange` / `predict_range_rate` are the only
places that convert between CasADi ``DM`` and NumPy (STYLE.md §2.6; the pseudorange
through the function's evaluation buffer, `_pseudorange_buffer`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np
import numpy.typing as npt

from gnss_obs.epoch import PreparedEpoch

__all__ = ["MeasurementModel", "build_measurement_model", "mapped_measurement_model",
           "predict_pseudorange", "predict_range_rate", "system_bias_matrix"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class MeasurementModel:
    """CasADi measurement functions (single satellite, or mapped over satellites).

    Attributes
    ----------
    pseudorange : casadi.Function
        ``(r_e[3], b_m, sat_pos_e[3], sat_clock_m, delays_m) -> (rho, H_r[1x3], H_b)``:
        predicted pseudorange (m) and its Jacobians w.r.t. the receiver ECEF position and
        the receiver clock bias (m).
    range_rate : casadi.Function
        ``(r_e[3], v_e[3], d_mps, sat_pos_e[3], sat_vel_e[3], sat_clock_drift_mps)
        -> (rho_dot, H_r[1x3], H_v[1x3], H_d)``: predicted range rate (m/s) and its
        Jacobians w.r.t. receiver position, velocity and clock drift (m/s).
    n_sat : int
        Number of satellites the functions are mapped over (1 = unmapped).
    """

    pseudorange: ca.Function
    range_rate: ca.Function
    n_sat: int = 1


@lru_cache(maxsize=1)
def build_measurement_model() -> MeasurementModel:
    """Build the single-satellite pseudorange and range-rate functions (once)."""
    r_e = ca.SX.sym("r_e", 3)
    v_e = ca.SX.sym("v_e", 3)
    b_m = ca.SX.sym("b_m")
    d_mps = ca.SX.sym("d_mps")
    sat_pos_e = ca.SX.sym("sat_pos_e", 3)
    sat_vel_e = ca.SX.sym("sat_vel_e", 3)
    sat_clock_m = ca.SX.sym("sat_clock_m")
    sat_clock_drift_mps = ca.SX.sym("sat_clock_drift_mps")
    delays_m = ca.SX.sym("delays_m")

    los = sat_pos_e - r_e
    geometric_range = ca.norm_2(los)
    rho = geometric_range + b_m - sat_clock_m + delays_m
    pseudorange = ca.Function(
        "pseudorange", [r_e, b_m, sat_pos_e, sat_clock_m, delays_m],
        [rho, ca.jacobian(rho, r_e), ca.jacobian(rho, b_m)],
        ["r_e", "b_m", "sat_pos_e", "sat_clock_m", "delays_m"], ["rho", "H_r", "H_b"])

    unit = los / geometric_range
    rho_dot = ca.dot(unit, sat_vel_e - v_e) + d_mps - sat_clock_drift_mps
    range_rate = ca.Function(
        "range_rate", [r_e, v_e, d_mps, sat_pos_e, sat_vel_e, sat_clock_drift_mps],
        [rho_dot, ca.jacobian(rho_dot, r_e), ca.jacobian(rho_dot, v_e),
         ca.jacobian(rho_dot, d_mps)],
        ["r_e", "v_e", "d_mps", "sat_pos_e", "sat_vel_e", "sat_clock_drift_mps"],
        ["rho_dot", "H_r", "H_v", "H_d"])
    return MeasurementModel(pseudorange, range_rate, 1)


@lru_cache(maxsize=64)
def mapped_measurement_model(n_sat: int) -> MeasurementModel:
    """The measurement functions mapped over `n_sat` satellites (built once per n).

    Satellite inputs are ``(k, n_sat)`` column blocks; receiver inputs may be given once
    (one column) and are broadcast. Outputs ``rho`` are ``(1, n_sat)``, Jacobians
    ``(1, 3 n_sat)`` (satellite after satellite).
    """
    if n_sat < 1:
        raise ValueError(f"n_sat must be >= 1, got {n_sat}")
    single = build_measurement_model()
    return MeasurementModel(single.pseudorange.map(n_sat), single.range_rate.map(n_sat), n_sat)


def _row(x) -> Array:
    return np.asarray(x, dtype=float).reshape(-1)


def _rows3(x, n: int) -> Array:
    return np.asarray(x, dtype=float).reshape(n, 3)


def predict_pseudorange(prepared: PreparedEpoch, *, r_e: npt.ArrayLike,
                        b_m: npt.ArrayLike) -> tuple[Array, Array, Array]:
    """Predicted pseudoranges of a prepared epoch and their Jacobians.

    Parameters
    ----------
    prepared : PreparedEpoch, N satellites
    r_e : array_like, shape (3,)
        Receiver ECEF position, m.
    b_m : array_like, shape (N,) or scalar
        Receiver clock bias seen by each satellite (reference + inter-system bias), m.

    Returns
    -------
    rho : ndarray, shape (N,)
        Pseudorange, m.
    H_r : ndarray, shape (N, 3)
        ∂ρ/∂r_e (minus the unit line of sight), dimensionless.
    H_b : ndarray, shape (N,)
        ∂ρ/∂b_m (ones).
    """
    n = len(prepared)
    buffer, evaluate = _pseudorange_buffer(n)
    # the mapped function's arguments column-major: (3, n) blocks satellite after
    # satellite, the receiver's position repeated for each
    args = [np.tile(np.asarray(r_e, dtype=float).reshape(3), n),
            np.ascontiguousarray(np.broadcast_to(np.asarray(b_m, dtype=float), (n,))),
            np.ascontiguousarray(prepared.sat_pos_e, dtype=float).reshape(-1),
            np.ascontiguousarray(prepared.sat_clock_m, dtype=float),
            np.ascontiguousarray(prepared.delays_m, dtype=float)]
    rho, H_r, H_b = np.empty(n), np.empty(3 * n), np.empty(n)
    for i, a in enumerate(args):
        buffer.set_arg(i, memoryview(a))
    for i, a in enumerate((rho, H_r, H_b)):
        buffer.set_res(i, memoryview(a))
    evaluate()
    return rho, H_r.reshape(n, 3), H_b


@lru_cache(maxsize=64)
def _pseudorange_buffer(n_sat: int):
    """`mapped_measurement_model(n_sat).pseudorange`'s evaluation buffer
    (``casadi.Function.buffer``: its arguments and results read and written in NumPy's
    memory, the same evaluation without the conversions to and from ``DM``: ~18 µs a call
    for 8 satellites against ~65 µs); the results dense, each its ``n_sat`` or ``3 n_sat``
    numbers."""
    f = mapped_measurement_model(n_sat).pseudorange
    if any(f.nnz_out(i) != f.numel_out(i) for i in range(f.n_out())):
        raise AssertionError("the pseudorange model's outputs must be dense")
    return f.buffer()


def predict_range_rate(prepared: PreparedEpoch, *, r_e: npt.ArrayLike, v_e: npt.ArrayLike,
                       d_mps: float) -> tuple[Array, Array, Array, Array]:
    """Predicted range rates of a prepared epoch and their Jacobians.

    Parameters
    ----------
    prepared : PreparedEpoch, N satellites
    r_e, v_e : array_like, shape (3,)
        Receiver ECEF position (m) and velocity (m/s).
    d_mps : float
        Receiver clock drift, m/s.

    Returns
    -------
    rho_dot : ndarray, shape (N,)
        Range rate, m/s.
    H_r : ndarray, shape (N, 3)
        ∂ρ̇/∂r_e, 1/s.
    H_v : ndarray, shape (N, 3)
        ∂ρ̇/∂v_e (minus the unit line of sight).
    H_d : ndarray, shape (N,)
        ∂ρ̇/∂d_mps (ones).
    """
    n = len(prepared)
    f = mapped_measurement_model(n).range_rate
    out = f(np.asarray(r_e, dtype=float), np.asarray(v_e, dtype=float), float(d_mps),
            prepared.sat_pos_e.T, prepared.sat_vel_e.T, prepared.sat_clock_drift_mps[None, :])
    rho_dot, H_r, H_v, H_d = out
    return _row(rho_dot), _rows3(H_r, n), _rows3(H_v, n), _row(H_d)


def system_bias_matrix(system: npt.ArrayLike, systems: str) -> Array:
    """Map clock states to satellites: reference clock plus one bias per other system.

    Parameters
    ----------
    system : array_like of str, shape (N,)
        System letter of each satellite.
    systems : str
        The systems in use; the first is the reference (its clock is state 0), each other
        system k has an inter-system bias state k (m).

    Returns
    -------
    S : ndarray, shape (N, len(systems))
        ``b_sat = S @ clock_states``: column 0 all ones, column k one where the satellite
        belongs to ``systems[k]``.
    """
    system = np.asarray(system)
    S = np.zeros((system.size, len(systems)))
    S[:, 0] = 1.0
    for k, letter in enumerate(systems[1:], start=1):
        S[:, k] = system == letter
    return S
