"""The columns of ``estimates.csv`` (after ``time_s, gps_time_s``), every filter's.

`ESTIMATE_COLUMNS` first, in that order, then the attitude, clock and biases
(`common_columns`), then the ``sigma_*`` of each, all assembled by `estimate_columns` (the
one place); `track_estimates` gives them for states on the track (the constrained and
GNSS-only filters), `state_columns` for any named states.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout

__all__ = ["ESTIMATE_COLUMNS", "estimate_columns", "track_estimates", "common_columns",
           "state_columns"]

Array = npt.NDArray[np.float64]


def state_columns(layout: StateLayout, x: Array, var: Array, names: dict[str, str]
                  ) -> dict[str, Array]:
    """Columns ``<column>`` and ``sigma_<column>`` for the states named in `names`.

    Parameters
    ----------
    layout : ekf.StateLayout
    x, var : ndarray, shape (K, n)
        States and their variances.
    names : dict of str to str
        State name -> column name (with its unit); states absent from the layout skip.
    """
    out: dict[str, Array] = {}
    for state, column in names.items():
        if state in layout.names:
            i = layout.index(state)
            out[column] = x[:, i]
            out["sigma_" + column] = np.sqrt(var[:, i])
    return out


#: Non-attitude states written as they are (column names carry the units).
_PLAIN_STATES = {"clock_bias": "clock_bias_m", "clock_drift": "clock_drift_mps",
                 "b_ax": "accel_bias_x_mps2", "b_ay": "accel_bias_y_mps2",
                 "b_az": "accel_bias_z_mps2", "b_gx": "gyro_bias_x_radps",
                 "b_gy": "gyro_bias_y_radps", "b_gz": "gyro_bias_z_radps",
                 "odo_scale": "odometer_scale"}


def track_estimates(track, layout: StateLayout, x: Array, var: Array) -> dict[str, Array]:
    """Estimate columns of filters whose position is ``s`` on `track`.

    Parameters
    ----------
    track : trackmodel.Track
    layout : ekf.StateLayout
    x, var : ndarray, shape (K, n)
        Stored states and the diagonal of their covariance.

    Returns
    -------
    dict of str to ndarray (K,)
        ``s_m, lat_deg, lon_deg, h_m, speed_mps, v_east_mps, v_north_mps, v_up_mps``, the
        attitude in degrees when estimated, clock, biases and inter-system biases, and the
        ``sigma_*`` of each (``sigma_east_m`` etc. are ``σ_s`` projected on the tangent).
    """
    s = np.clip(x[:, layout.index("s")], 0.0, track.length_m)
    v = x[:, layout.index("v")]
    point = track.at(s)
    sig_s = np.sqrt(var[:, layout.index("s")])
    sig_v = np.sqrt(var[:, layout.index("v")])
    u = point.u_n
    cols = {"s_m": s, "lat_deg": np.degrees(point.lat), "lon_deg": np.degrees(point.lon),
            "h_m": point.h, "speed_mps": v, "v_east_mps": v * u[:, 0],
            "v_north_mps": v * u[:, 1], "v_up_mps": v * u[:, 2]}
    return estimate_columns(layout, x, var, position=cols, position_sigma={
        "sigma_s_m": sig_s, "sigma_east_m": sig_s * np.abs(u[:, 0]),
        "sigma_north_m": sig_s * np.abs(u[:, 1]), "sigma_up_m": sig_s * np.abs(u[:, 2]),
        "sigma_speed_mps": sig_v})


#: The first columns of ``estimates.csv`` after ``time_s, gps_time_s``, every filter's, in
#: this order: distance along the track (m), geodetic position (deg, deg, m), signed speed
#: along the track (m/s) and ENU velocity (m/s).
ESTIMATE_COLUMNS = ("s_m", "lat_deg", "lon_deg", "h_m", "speed_mps", "v_east_mps",
                    "v_north_mps", "v_up_mps")


def estimate_columns(layout: StateLayout, x: Array, var: Array, *,
                     position: dict[str, Array], position_sigma: dict[str, Array]
                     ) -> dict[str, Array]:
    """A filter's ``estimates.csv`` columns: `ESTIMATE_COLUMNS` (`position`), the states
    written as they are (`common_columns`), then the σ of the position (`position_sigma`:
    ``sigma_s_m``, ``sigma_east_m``, ...) and of the others.

    Parameters
    ----------
    layout : ekf.StateLayout
    x, var : ndarray, shape (K, n)
        Stored states and the diagonal of their covariance.
    position : dict of str to ndarray (K,)
        Exactly the `ESTIMATE_COLUMNS`.
    position_sigma : dict of str to ndarray (K,)

    Raises
    ------
    ValueError
        If `position` is not the `ESTIMATE_COLUMNS` in order (a filter's bug).
    """
    if tuple(position) != ESTIMATE_COLUMNS:
        raise ValueError(f"estimate columns {tuple(position)} are not {ESTIMATE_COLUMNS}")
    common, common_sigma = common_columns(layout, x, var)
    return {**position, **common, **position_sigma, **common_sigma}


def common_columns(layout: StateLayout, x: Array, var: Array
                   ) -> tuple[dict[str, Array], dict[str, Array]]:
    """Columns of the states written as they are, whatever the filter's position states.

    Parameters
    ----------
    layout : ekf.StateLayout
    x, var : ndarray, shape (K, n)
        Stored states and the diagonal of their covariance.

    Returns
    -------
    values, sigmas : dict of str to ndarray (K,)
        The attitude in degrees (yaw in [0, 360)), clock, IMU biases and inter-system
        biases of the layout, and their ``sigma_*`` (written after the values).
    """
    cols: dict[str, Array] = {}
    sig: dict[str, Array] = {}
    for name in ("yaw", "pitch", "roll"):
        if name in layout.names:
            i = layout.index(name)
            angle = x[:, i] % (2 * np.pi) if name == "yaw" else x[:, i]
            cols[f"{name}_deg"] = np.degrees(angle)
            sig[f"sigma_{name}_deg"] = np.degrees(np.sqrt(var[:, i]))
    for key, value in state_columns(layout, x, var, _PLAIN_STATES).items():
        (sig if key.startswith("sigma_") else cols)[key] = value
    for name in layout.names:
        if name.startswith("isb_"):
            cols[f"{name}_m"] = x[:, layout.index(name)]
            sig[f"sigma_{name}_m"] = np.sqrt(var[:, layout.index(name)])
    return cols, sig
