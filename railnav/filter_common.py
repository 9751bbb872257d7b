"""Pieces shared by the filters whose position is the along-track distance ``s``.

* `GnssRowBuilder`: an epoch's pseudorange/range-rate `ekf.Observation` s at the prior's
  point on the track, and the per-row record (satellite, kind) for ``innovations.csv``;
* `track_estimates`: the estimate columns of ``estimates.csv`` from states on the track.
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.update import Observation
from railnav.gnss_rows import (build_gnss_rows, pseudorange_parameters, range_rate_parameters,
                               track_rows)

__all__ = ["GnssRowBuilder", "track_estimates", "ROW_KINDS", "state_columns", "scalar_point",
           "REFERENCE_REUSE_M"]

Array = npt.NDArray[np.float64]

#: A reference track point this close to the prior's ``s`` (m) is used as it is: the
#: rows' second-order expansion errs by ~δ³|dk/ds|/6, below 1e-9 m at 1 m on a 300 m curve.
REFERENCE_REUSE_M = 1.0
#: Kinds of GNSS rows, as written in ``innovations.csv``.
ROW_KINDS = ("pseudorange", "range_rate")


class GnssRowBuilder:
    """Builds the GNSS rows of each epoch and remembers what each row was.

    Parameters
    ----------
    track : trackmodel.Track
    layout : ekf.StateLayout
        With states ``s, v, clock_bias, clock_drift`` (+ `isb_names`).
    gnss : railnav.gnss_epochs.GnssEpochs or None
    config : railnav.NavigatorConfig
    isb_names : tuple of str
        Inter-system bias states, in the order of ``gnss.config.systems[1:]``.

    Attributes
    ----------
    rows_sv, rows_kind : list of ndarray
        Per processed epoch, the satellite and kind of each row (in update order).
    """

    def __init__(self, track, layout: StateLayout, gnss, config, isb_names: tuple[str, ...]):
        self.track, self.layout, self.gnss, self.config = track, layout, gnss, config
        self.rows = build_gnss_rows(layout, isb_names)
        self.isb_systems = tuple(name.removeprefix("isb_") for name in isb_names)
        self.i_s = layout.index("s")
        self.rows_sv: list[np.ndarray] = []
        self.rows_kind: list[np.ndarray] = []

    def observations(self, index: int, x: Array, reference=None) -> list[Observation]:
        """The rows of GNSS epoch `index` at the prior state ``x``.

        Parameters
        ----------
        index : int
        x : ndarray, shape (n,)
        reference : trackmodel.TrackPoint, optional
            A scalar track point near the prior's ``s`` to linearize at (the rows are exact
            to second order in ``s − s_ref``); queried at ``s`` when absent or farther than
            `REFERENCE_REUSE_M`.
        """
        s = min(max(float(x[self.i_s]), 0.0), self.track.length_m)
        point = reference
        if point is None or abs(float(point.s) - s) > REFERENCE_REUSE_M:
            point = self.track.at(s)
        prepared = self.gnss.prepare(index, point.r_e)
        part = track_rows(point, earth=self.track.earth)
        obs, sv, kind = [], [], []
        if len(prepared):
            obs.append(Observation(self.rows.pseudorange, prepared.pseudorange_m[:, None],
                                   prepared.sigma_pr_m ** 2,
                                   pseudorange_parameters(part, prepared, self.isb_systems)))
            sv.append(prepared.sv)
            kind.append(np.full(len(prepared), ROW_KINDS[0], dtype=object))
        if self.config.use_doppler and len(prepared):
            dop = prepared.subset(np.isfinite(prepared.range_rate_mps))
            if len(dop):
                obs.append(Observation(self.rows.range_rate, dop.range_rate_mps[:, None],
                                       dop.sigma_rr_mps ** 2, range_rate_parameters(part, dop)))
                sv.append(dop.sv)
                kind.append(np.full(len(dop), ROW_KINDS[1], dtype=object))
        self.rows_sv.append(np.concatenate(sv) if sv else np.zeros(0, dtype=object))
        self.rows_kind.append(np.concatenate(kind) if kind else np.zeros(0, dtype=object))
        return obs


def scalar_point(points, i: int):
    """Element `i` of a `trackmodel.TrackPoint` of arrays, as a scalar point."""
    return type(points)(**{f.name: getattr(points, f.name)[i] for f in fields(points)})


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
                 "b_gy": "gyro_bias_y_radps", "b_gz": "gyro_bias_z_radps"}


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
    for name in ("yaw", "pitch", "roll"):
        if name in layout.names:
            i = layout.index(name)
            angle = x[:, i] % (2 * np.pi) if name == "yaw" else x[:, i]
            cols[f"{name}_deg"] = np.degrees(angle)
    cols.update({k: v_ for k, v_ in state_columns(layout, x, var, _PLAIN_STATES).items()
                 if not k.startswith("sigma_")})
    for name in layout.names:
        if name.startswith("isb_"):
            cols[f"{name}_m"] = x[:, layout.index(name)]
    sig = {"sigma_s_m": sig_s, "sigma_east_m": sig_s * np.abs(u[:, 0]),
           "sigma_north_m": sig_s * np.abs(u[:, 1]), "sigma_up_m": sig_s * np.abs(u[:, 2]),
           "sigma_speed_mps": sig_v}
    for name in ("yaw", "pitch", "roll"):
        if name in layout.names:
            sig[f"sigma_{name}_deg"] = np.degrees(np.sqrt(var[:, layout.index(name)]))
    sig.update({k: v_ for k, v_ in state_columns(layout, x, var, _PLAIN_STATES).items()
                if k.startswith("sigma_")})
    for name in layout.names:
        if name.startswith("isb_"):
            sig[f"sigma_{name}_m"] = np.sqrt(var[:, layout.index(name)])
    cols.update(sig)
    return cols
