"""Plots of a navigation run: errors with ±3σ bands, estimates, the track with the estimate.

Figures are built with `matplotlib.figure.Figure` (no global pyplot state, no backend
change) and written to PNG by the caller's path. GNSS outages are shaded.
"""
from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from trackmodel.earth import ecef_to_enu, geodetic_to_ecef

__all__ = ["plot_errors", "plot_estimates", "plot_track_estimate", "errors_figure",
           "estimates_figure", "track_estimate_figure", "SIGMA_BAND"]

#: Width of the uncertainty bands, in standard deviations.
SIGMA_BAND = 3.0
_OUTAGE_STYLE = dict(color="0.85", zorder=0, lw=0)


def _shade(ax, outages) -> None:
    for start, duration in outages:
        ax.axvspan(start, start + duration, **_OUTAGE_STYLE)


def _save(fig: Figure, path: str | os.PathLike) -> None:
    from trackmodel.files import atomic_write
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=110)


def plot_errors(errors, result, path: str | os.PathLike) -> None:
    """`errors_figure` written to a PNG file."""
    _save(errors_figure(errors, result), path)


def plot_estimates(result, path: str | os.PathLike) -> None:
    """`estimates_figure` written to a PNG file."""
    _save(estimates_figure(result), path)


def plot_track_estimate(track, result, path: str | os.PathLike, *, truth=None) -> None:
    """`track_estimate_figure` written to a PNG file."""
    _save(track_estimate_figure(track, result, truth=truth), path)


def errors_figure(errors, result) -> Figure:
    """Errors against the truth with the filter's ±3σ bands, outages shaded.

    Parameters
    ----------
    errors : railnav.evaluation.metrics.ErrorSeries
    result : railnav.NavigationResult

    Returns
    -------
    matplotlib.figure.Figure
    """
    est, t = result.estimates, errors.time_s
    panels = [("along_track_m", "sigma_s_m", 1.0, "along-track error [m]"),
              ("speed_mps", "sigma_speed_mps", 1.0, "speed error [m/s]")]
    if "sigma_east_m" in est and "sigma_s_m" not in est:   # an unconstrained filter
        panels[0] = ("position_3d_m", None, 1.0, "3-D position error [m]")
    if "sigma_cross_track_m" in est:   # a filter off the track: its cross and vertical errors
        panels[1:1] = [("cross_track_m", "sigma_cross_track_m", 1.0, "cross-track error [m]"),
                       ("vertical_m", "sigma_up_m", 1.0, "vertical error [m]")]
    for name in ("yaw", "pitch", "roll"):
        if f"sigma_{name}_deg" in est:
            panels.append((f"{name}_rad", f"sigma_{name}_deg", np.pi / 180.0,
                           f"{name} error [rad]"))
    fig = Figure(figsize=(9, 2.0 * len(panels) + 0.6), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (err_name, sig_name, scale, label) in zip(axes, panels):
        _shade(ax, result.outages)
        ax.plot(t, getattr(errors, err_name), lw=0.8, color="C0", label="error")
        if sig_name is not None and sig_name in est:
            band = SIGMA_BAND * est[sig_name].to_numpy() * scale
            ax.fill_between(t, -band, band, color="C1", alpha=0.25, lw=0, label="±3σ")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time from start [s]  (grey: GNSS outage)")
    fig.suptitle(f"{result.filter} filter: errors against the truth")
    return fig


def estimates_figure(result) -> Figure:
    """Estimated distance, speed and attitude with their σ (for runs without truth)."""
    est = result.estimates
    t = est["time_s"].to_numpy()
    panels = [(c, f"sigma_{c}" if f"sigma_{c}" in est else None)
              for c in ("s_m", "speed_mps", "yaw_deg", "pitch_deg", "roll_deg") if c in est]
    fig = Figure(figsize=(9, 1.9 * len(panels) + 0.6), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (col, sig) in zip(axes, panels):
        _shade(ax, result.outages)
        ax.plot(t, est[col], lw=0.8)
        if sig is not None:
            ax2 = ax.twinx()
            ax2.plot(t, est[sig], lw=0.6, color="C1")
            ax2.set_ylabel("σ", color="C1")
        ax.set_ylabel(col)
        ax.grid(True, lw=0.3)
    axes[-1].set_xlabel("time from start [s]  (grey: GNSS outage)")
    fig.suptitle(f"{result.filter} filter: estimates")
    return fig


def track_estimate_figure(track, result, *, truth=None) -> Figure:
    """Map view (local east/north, m) of the track, the estimate and the outage spans."""
    s = np.linspace(0.0, track.length_m, 2000)
    line = track.at(s)
    lat0, lon0, h0 = float(line.lat[0]), float(line.lon[0]), float(line.h[0])

    def enu(lat_deg, lon_deg, h_m):
        r = geodetic_to_ecef(np.radians(lat_deg), np.radians(lon_deg), h_m, earth=track.earth)
        return ecef_to_enu(r, lat0=lat0, lon0=lon0, h0=h0, earth=track.earth)

    track_n = ecef_to_enu(line.r_e, lat0=lat0, lon0=lon0, h0=h0, earth=track.earth)
    est = result.estimates
    est_n = enu(est["lat_deg"].to_numpy(), est["lon_deg"].to_numpy(), est["h_m"].to_numpy())
    fig = Figure(figsize=(7, 6.5), layout="constrained")
    ax = fig.subplots()
    ax.plot(track_n[:, 0], track_n[:, 1], color="0.6", lw=3, label="track")
    ax.plot(est_n[:, 0], est_n[:, 1], color="C0", lw=1, label="estimate")
    t = est["time_s"].to_numpy()
    for k, (start, duration) in enumerate(result.outages):
        m = (t >= start) & (t < start + duration)
        ax.plot(est_n[m, 0], est_n[m, 1], color="C3", lw=2,
                label="GNSS outage" if k == 0 else None)
    if truth is not None:
        ax.plot(*enu(np.degrees(truth.lat), np.degrees(truth.lon), truth.h)[:, :2].T,
                color="k", lw=0.6, ls="--", label="truth")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, lw=0.3)
    ax.set_title(f"{result.filter} filter on the track")
    return fig
