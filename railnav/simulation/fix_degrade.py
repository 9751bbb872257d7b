"""Recorded fixes degraded to single-point quality: white noise plus a Gauss–Markov bias
per horizontal axis (issue 13's acceptance: what parallel tracks 4–6 m apart look like
to a receiver without corrections).

`degrade_positions` adds to each fix, per axis (east, north), white noise of σ
``white_m`` and a first-order Gauss–Markov bias of σ ``bias_m`` and correlation time
``tau_s`` (stationary from the first fix: ``b_{k+1} = ρ b_k + σ√(1−ρ²) w``, ``ρ =
e^{−Δt/τ}``), seeded; `degrade_log` writes a fix log (the Belgian CSV layout) with its
positions so degraded and every row flagged ``SINGLE``.
"""
from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.earth import C_n_e, ecef_to_geodetic, geodetic_to_ecef

__all__ = ["degrade_positions", "degrade_log", "SPP_WHITE_M", "SPP_BIAS_M", "SPP_TAU_S"]

Array = npt.NDArray[np.float64]

#: Issue 13's single-point quality: 2 m white + 2 m Gauss–Markov bias (τ 60 s) per axis.
SPP_WHITE_M, SPP_BIAS_M, SPP_TAU_S = 2.0, 2.0, 60.0


def degrade_positions(lat: Array, lon: Array, time_s: Array, rng: np.random.Generator, *,
                      white_m: float = SPP_WHITE_M, bias_m: float = SPP_BIAS_M,
                      tau_s: float = SPP_TAU_S) -> tuple[Array, Array, Array]:
    """Positions (rad) with the module docstring's errors added, and the errors (N, 2)
    east/north, m."""
    lat, lon, t = (np.asarray(a, dtype=float) for a in (lat, lon, time_s))
    n = lat.size
    bias = np.zeros((n, 2))
    bias[0] = bias_m * rng.standard_normal(2)
    for k in range(1, n):
        rho = np.exp(-max(t[k] - t[k - 1], 0.0) / tau_s)
        bias[k] = rho * bias[k - 1] + bias_m * np.sqrt(1.0 - rho * rho) * rng.standard_normal(2)
    error = bias + white_m * rng.standard_normal((n, 2))
    r = geodetic_to_ecef(lat, lon, np.zeros(n))
    d_n = np.column_stack([error, np.zeros(n)])
    r = r + np.einsum("kij,kj->ki", C_n_e(lat, lon), d_n)
    lat2, lon2, _ = ecef_to_geodetic(r)
    return lat2, lon2, error


def degrade_log(source: str | os.PathLike, target: str | os.PathLike, *, seed: int,
                **errors) -> pd.DataFrame:
    """A Belgian fix log (``latitude, longitude, timestamp, position_type, ...``) with
    degraded positions (`degrade_positions`, keywords passed on) written to `target`,
    every row ``SINGLE``; returns the table written (with ``error_east_m``,
    ``error_north_m`` not written)."""
    raw = pd.read_csv(source)
    stamps = pd.to_datetime(raw["timestamp"], format="ISO8601")
    t = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy()
    lat, lon, err = degrade_positions(np.radians(raw["latitude"].to_numpy()),
                                      np.radians(raw["longitude"].to_numpy()), t - t[0],
                                      np.random.default_rng(seed), **errors)
    out = raw.copy()
    out["latitude"], out["longitude"] = np.degrees(lat), np.degrees(lon)
    for name in ("geom_latitude", "geom_longitude"):
        if name in out:
            out[name] = out["latitude" if "latitude" in name else "longitude"]
    out["position_type"] = "SINGLE"
    out.to_csv(target, index=False)
    return out.assign(error_east_m=err[:, 0], error_north_m=err[:, 1])
