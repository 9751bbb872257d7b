"""What a navigation run produces: estimates, innovations and filter statistics.

`NavigationResult.estimates` is the ``estimates.csv`` table (`estimates_frame`, the one
place that builds it): ``time_s`` (from the trip start), ``gps_time_s`` and the filter's
columns (`railnav.filters.estimate_columns.ESTIMATE_COLUMNS`: ``s_m, lat_deg, lon_deg, h_m,
speed_mps, v_east_mps, ...``, then ``yaw_deg, ...``, clock, biases, and ``sigma_*`` of
each; `railnav.filters.estimate_columns.estimate_columns`); with the divergence monitor
(`railnav.navigation.monitor`, track-based filters), then ``status`` (``ok``, ``degraded``,
``lost``), ``s_min_m``, ``s_max_m``, ``protection_level_m`` (integrity risk 1e-5 per
epoch) and ``protection_level_risk_0p001_m`` (`railnav.navigation.protection`).
`NavigationResult.innovations` is ``innovations.csv``: one
row per GNSS measurement used or rejected (``time_s, gps_time_s, epoch, sv, kind,
innovation, sigma, nis, accepted, status, fault_probability, clock_jump_m, noise_scale``;
innovation in
m or m/s by kind; a GNSS position fix has the rows of `railnav.filters.fix_rows`, ``sv``
``fix:<class>``). ``status`` is ``used``, ``rejected`` (this epoch) or ``excluded`` (its
channel is out, `railnav.filters.fault_detection`); ``accepted`` is ``status == "used"``;
``fault_probability`` is the row's posterior fault probability and ``clock_jump_m`` a
receiver clock jump declared at the row's epoch (NaN for filters without the fault screen,
and where none was); ``noise_scale`` the factor on the σ of the row's kind at its epoch
(`railnav.filters.noise_scale`; NaN for rows it does not scale).

A run on tracks without heights (a network read without them, `trackmodel.network.Network`
``heights``) knows no height: `without_heights` empties the `HEIGHT_COLUMNS` of its
estimates (NaN: an empty CSV field, ``null`` in JSON).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt
import pandas as pd

from ekf.history import FilterResult
from ekf.layout import StateLayout
from railnav.filters.fix_rows import FIX_ROW_KINDS
from railnav.filters.noise_scale import row_scales, scale_statistics
from railnav.filters.sensor_rows import sensor_statistics
from railnav.navigation.statuses import STATUSES, status_at
from railnav.navigation.protection import protection_columns

__all__ = ["NavigationResult", "estimates_frame", "integrity_columns", "monitor_statistics",
           "without_heights", "HEIGHT_COLUMNS", "CSV_FLOAT_FORMAT", "CSV_DECIMALS"]

#: CSV float format of the output tables: 12 significant digits (µm at 10⁶ m, 1e-10° in
#: degrees), except the times (`CSV_DECIMALS`).
CSV_FLOAT_FORMAT = "%.12g"
#: Columns of the output tables written with fixed decimals: times to the µs (12
#: significant digits would keep ``gps_time_s``, ~1.3e9 s, to 10 ms only).
CSV_DECIMALS = {"time_s": 6, "gps_time_s": 6}

Array = npt.NDArray[np.float64]

#: Columns of ``estimates.csv`` that a track without heights cannot give: the ellipsoidal
#: height, the vertical velocity and their σ, and the pitch (which follows the track's
#: grade) and its σ.
HEIGHT_COLUMNS = ("h_m", "v_up_mps", "sigma_up_m", "pitch_deg", "sigma_pitch_deg")


def estimates_frame(filt_obj, t: npt.NDArray[np.float64], x: npt.NDArray[np.float64],
                    P_packed: npt.NDArray[np.float64], *,
                    start_gps_time_s: float) -> pd.DataFrame:
    """The ``estimates.csv`` rows of stored states (module docstring).

    Parameters
    ----------
    filt_obj : railnav.filters.protocol.Filter
    t : ndarray, shape (K,)
        s from the trip start.
    x : ndarray, shape (K, n)
    P_packed : ndarray, shape (K, n(n+1)/2)
    start_gps_time_s : float
        GPS time of ``t = 0``, s.
    """
    head = {"time_s": t, "gps_time_s": t + start_gps_time_s}
    return pd.DataFrame({**head, **filt_obj.estimates(x, P_packed)})


def without_heights(result: "NavigationResult") -> "NavigationResult":
    """`result` with the `HEIGHT_COLUMNS` of its estimates NaN (module docstring): the run's
    tracks have ``h = 0`` as a placeholder, not as a height."""
    est = result.estimates.copy()
    est[[c for c in HEIGHT_COLUMNS if c in est.columns]] = np.nan
    return replace(result, estimates=est)


@dataclass(frozen=True, eq=False)
class NavigationResult:
    """A navigation run.

    Attributes
    ----------
    filter : str
        ``constrained``, ``unconstrained`` or ``gnss-only``.
    layout : ekf.StateLayout
    start_gps_time_s : float
        GPS time of ``time_s = 0``, s.
    time_s : ndarray, shape (K,)
        Stored sample times, s from the trip start.
    x : ndarray, shape (K, n)
        State after all measurements at each stored sample.
    P : ndarray, shape (K, n(n+1)/2)
        Its covariance, packed (`ekf.packing`).
    estimates : pandas.DataFrame
        The ``estimates.csv`` table (module docstring).
    innovations : pandas.DataFrame
        The ``innovations.csv`` table (module docstring).
    nis_continuous_mean : float
        Mean NIS of the accelerometer pseudo-observation per step (expected: its dimension,
        2), NaN without one.
    nis_continuous_dof : int
    outages : tuple of (start_s, duration_s)
    runtime_s : float
        Wall time of `railnav.navigate`, s.
    n_steps, n_epochs : int
        Filter steps and GNSS updates.
    raw : ekf.FilterResult
    filter_object : object
        The filter that ran (`railnav.filters.constrained.ConstrainedFilter`, ...): its
        layout, track and ``truth_states`` for evaluation.
    left_track : dict or None
        Where the run stopped because ``s`` left the track
        (`railnav.navigation.loop.TrackEndWatch`, `railnav.navigation.loop.beyond_track`'s
        record: ``time_s, gps_time_s, s_m, sigma_s_m, end, track_length_m``); None when it
        ran through the data.
    """

    filter: str
    layout: StateLayout
    start_gps_time_s: float
    time_s: Array
    x: Array
    P: Array
    estimates: pd.DataFrame
    innovations: pd.DataFrame
    nis_continuous_mean: float
    nis_continuous_dof: int
    outages: tuple
    runtime_s: float
    n_steps: int
    n_epochs: int
    raw: FilterResult = field(repr=False)
    filter_object: object = field(repr=False, default=None)
    left_track: dict | None = None
    monitor: pd.DataFrame | None = field(repr=False, default=None)

    @classmethod
    def assemble(cls, filt_obj, config, result: FilterResult, *, start_gps_time_s: float,
                 outages, epoch_indices, epoch_times, runtime_s: float,
                 left_track: dict | None = None,
                 monitor: pd.DataFrame | None = None) -> "NavigationResult":
        """Build the result of a finished run (called by `railnav.navigate`); with the
        `monitor`'s records, ``estimates.csv`` gets the integrity columns
        (`integrity_columns`)."""
        P = result.P if result.P is not None else np.zeros((result.t.size, 0))
        estimates = estimates_frame(filt_obj, result.t, result.x, P,
                                    start_gps_time_s=start_gps_time_s)
        if monitor is not None:
            estimates = estimates.assign(**integrity_columns(estimates, monitor, config))
        innovations = _innovations(result, filt_obj, start_gps_time_s)
        n_c = result.innov_c.shape[1] if result.innov_c.ndim == 2 else 0
        nis_c = result.nis_c_sum / result.nis_c_count if result.nis_c_count else float("nan")
        return cls(filter=config.filter, layout=result.layout,
                   start_gps_time_s=float(start_gps_time_s), time_s=result.t, x=result.x, P=P,
                   estimates=estimates, innovations=innovations, nis_continuous_mean=nis_c,
                   nis_continuous_dof=n_c, outages=tuple(tuple(o) for o in outages),
                   runtime_s=float(runtime_s), n_steps=int(result.n_steps),
                   n_epochs=int(result.t_d.size), raw=result, filter_object=filt_obj,
                   left_track=left_track, monitor=monitor)

    @property
    def final_status(self) -> str | None:
        """The monitor's status at the last tested epoch (None without a monitor)."""
        if self.monitor is None or not len(self.monitor):
            return None
        return str(self.monitor["status"].iloc[-1])

    def statistics(self) -> dict:
        """Filter self-consistency figures for ``summary.json`` (no truth needed)."""
        inn = self.innovations
        out = {"nis_continuous_mean": _finite_or_none(self.nis_continuous_mean),
               "nis_continuous_dof": self.nis_continuous_dof,
               "gnss_epochs": self.n_epochs, "gnss_rows": int(len(inn)),
               "gnss_rows_rejected": int((~inn["accepted"]).sum()) if len(inn) else 0}
        if len(inn):
            out["gnss_rows_excluded"] = int((inn["status"] == "excluded").sum())
            jumps = inn.groupby("epoch")["clock_jump_m"].first().dropna()
            out["clock_jumps"] = [{"time_s": float(inn.loc[inn["epoch"] == e, "time_s"].iloc[0]),
                                   "jump_m": float(v)} for e, v in jumps.items()]
        fix_kinds = [k for k in FIX_ROW_KINDS if len(inn) and (inn["kind"] == k).any()]
        for kind in ("pseudorange", "range_rate", *fix_kinds):
            rows = inn[(inn["kind"] == kind) & inn["accepted"]] if len(inn) else inn
            out[f"nis_{kind}_mean"] = _finite_or_none(float(rows["nis"].mean())) \
                if len(rows) else None
        if fix_kinds:
            fix = inn[inn["kind"].isin(fix_kinds)]
            used = fix.groupby("epoch")["accepted"].all()
            out["fix_epochs"], out["fixes_rejected"] = int(used.size), int((~used).sum())
        out.update(sensor_statistics(inn))      # odometer (slip episodes) and balises
        out.update(scale_statistics(inn))
        if self.monitor is not None:
            out["monitor"] = monitor_statistics(self.monitor, self.estimates)
        return out


def integrity_columns(estimates: pd.DataFrame, monitor: pd.DataFrame, config) -> dict:
    """``status`` (`railnav.navigation.statuses.status_at`) and the protection columns
    (`railnav.navigation.protection.protection_columns`) of the `estimates` rows."""
    status = status_at(monitor, estimates["time_s"].to_numpy())
    cols = {"status": status}
    cols.update(protection_columns(estimates.assign(status=status), monitor, config))
    return cols


def monitor_statistics(monitor: pd.DataFrame, estimates: pd.DataFrame) -> dict:
    """Status counts of the tested epochs and of the estimate rows, the recoveries and
    the final status (``summary.json`` ``statistics.monitor``)."""
    epochs = monitor["status"].value_counts()
    rows = estimates["status"].value_counts() if "status" in estimates else {}
    return {"epochs": {k: int(epochs.get(k, 0)) for k in STATUSES},
            "estimate_rows": {k: int(rows.get(k, 0)) for k in STATUSES},
            "recoveries": int((monitor["action"] != "").sum()),
            "final_status": str(monitor["status"].iloc[-1]) if len(monitor) else None}


def _finite_or_none(value: float):
    return float(value) if np.isfinite(value) else None


def _innovations(result: FilterResult, filt_obj, start_gps_time_s: float) -> pd.DataFrame:
    """One row per GNSS measurement, with the satellite and kind the filter recorded."""
    screen = getattr(filt_obj, "screen", None)
    if screen is not None and len(screen.epochs) == result.t_d.size:
        rows = screen.frame()
        out = _screened_innovations(result, rows, start_gps_time_s)
        out["noise_scale"] = _noise_scales(filt_obj, rows["screen_epoch"], rows["kind"])
        return out
    builder = getattr(filt_obj, "rows", None)
    sv = np.concatenate(builder.rows_sv) if builder is not None and builder.rows_sv else \
        np.zeros(0, dtype=object)
    kind = np.concatenate(builder.rows_kind) if builder is not None and builder.rows_kind else \
        np.zeros(0, dtype=object)
    n = result.innov_d.size
    if sv.size != n:   # an epoch record the builder did not see: keep numbers, drop labels
        sv = np.full(n, "", dtype=object)
        kind = np.full(n, "", dtype=object)
    t = result.t_d[result.epoch_of] if n else np.zeros(0)
    sigma = np.sqrt(result.s_d)
    return pd.DataFrame({"time_s": t, "gps_time_s": t + start_gps_time_s,
                         "epoch": result.epoch_of, "sv": sv, "kind": kind,
                         "innovation": result.innov_d, "sigma": sigma,
                         "nis": (result.innov_d / sigma) ** 2 if n else np.zeros(0),
                         "accepted": result.accepted,
                         "status": np.where(result.accepted, "used", "rejected").astype(object),
                         "fault_probability": np.full(n, np.nan),
                         "clock_jump_m": np.full(n, np.nan),
                         "noise_scale": _noise_scales(filt_obj, result.epoch_of, kind)})


def _noise_scales(filt_obj, epoch, kind) -> Array:
    """``noise_scale``: each GNSS row's σ factor at its epoch
    (`railnav.filters.noise_scale.row_scales`; NaN without a scale)."""
    scale = getattr(filt_obj, "noise_scale", None)
    return row_scales(scale.history if scale is not None else [], epoch, kind)


def _screened_innovations(result: FilterResult, rows: pd.DataFrame,
                          start_gps_time_s: float) -> pd.DataFrame:
    """Every screened row (`railnav.filters.fault_detection.RowScreen.frame`); the used ones carry
    the update's own innovation, σ and acceptance (its χ² gate may still reject)."""
    used = (rows["status"] == "used").to_numpy()
    if used.sum() != result.innov_d.size:
        raise ValueError(f"{used.sum()} rows passed the screen but the filter updated with "
                         f"{result.innov_d.size}")
    accepted = np.zeros(len(rows), dtype=bool)
    accepted[used] = result.accepted
    status = rows["status"].to_numpy(dtype=object).copy()   # object even with no row
    status[used & ~accepted] = "rejected"
    innovation, sigma = rows["innovation"].to_numpy().copy(), rows["sigma"].to_numpy().copy()
    innovation[used], sigma[used] = result.innov_d, np.sqrt(result.s_d)
    epoch = rows["screen_epoch"].to_numpy()
    t = result.t_d[epoch] if len(rows) else np.zeros(0)
    return pd.DataFrame({"time_s": t, "gps_time_s": t + start_gps_time_s, "epoch": epoch,
                         "sv": rows["sv"].to_numpy(), "kind": rows["kind"].to_numpy(),
                         "innovation": innovation, "sigma": sigma,
                         "nis": (innovation / sigma) ** 2, "accepted": accepted,
                         "status": status,
                         "fault_probability": rows["fault_probability"].to_numpy(),
                         "clock_jump_m": rows["clock_jump_m"].to_numpy()})
