"""The figure of a single-point solution (``spp.png``): map, errors with their σ and
protection levels, satellites.

Left, the map in metres from the first fix: the reference path (when given), the fixes, start
(▶) and end (■). Right, against time from the first epoch, epochs without a fix shaded grey:

* with a reference: east, north and up errors with the solution's ``±3σ``; the horizontal
  error against the HPL and the vertical against the VPL (protection-level-style figures of
  the RAIM, `gnss_obs.raim`);
* without: the 1σ of east, north and up, and HPL/VPL;
* the satellites tracked and used.

Conventions of `railnav.evaluation.plot_style` (words and units, robust limits).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from railnav.evaluation.plot_style import (
    OUTAGE_STYLE,
    SIGMA_BAND,
    limit_axis,
    plain_axis,
    robust_limit,
    sigma_band,
)
from trackmodel.earth import ecef_to_enu, geodetic_to_ecef

__all__ = ["spp_figure"]

_MATCH_DECIMALS = 3            # epochs matched on gps_time_s to 1 ms (spp_accuracy)
_TIME_LABEL = "time from the first epoch (s)"


def _enu(frame: pd.DataFrame, origin: dict) -> np.ndarray:
    r = geodetic_to_ecef(np.deg2rad(frame["lat_deg"].to_numpy()),
                         np.deg2rad(frame["lon_deg"].to_numpy()), frame["h_m"].to_numpy())
    return ecef_to_enu(r, **origin)


def _map(ax, solution: pd.DataFrame, reference: pd.DataFrame | None) -> None:
    ok = solution[np.isfinite(solution["lat_deg"].to_numpy())]
    if ok.empty:
        ax.text(0.5, 0.5, "no fix", transform=ax.transAxes, ha="center")
        return
    first = ok.iloc[0]
    origin = dict(lat0=np.deg2rad(first["lat_deg"]), lon0=np.deg2rad(first["lon_deg"]),
                  h0=float(first["h_m"]))
    if reference is not None:
        ref = _enu(reference, origin)
        ax.plot(ref[:, 0], ref[:, 1], "k-", lw=1.0, label="reference")
    fix = _enu(ok, origin)
    ax.plot(fix[:, 0], fix[:, 1], ".", color="C0", ms=3, label="single-point fixes")
    ax.plot(*fix[0, :2], ">", color="C2", ms=10, mec="k", label="start")
    ax.plot(*fix[-1, :2], "s", color="C3", ms=9, mec="k", label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="east of the first fix (m)", ylabel="north of the first fix (m)",
           title="map")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)


def _with_errors(solution: pd.DataFrame, errors: pd.DataFrame) -> pd.DataFrame:
    """The solution's rows (σ, protection levels) with the errors of the same epochs."""
    left = solution.assign(key=np.round(solution["gps_time_s"], _MATCH_DECIMALS))
    right = errors.drop(columns="gps_time_s").assign(
        key=np.round(errors["gps_time_s"], _MATCH_DECIMALS))
    return left.merge(right, on="key", how="left")


def _error_panels(axes, t, table: pd.DataFrame) -> None:
    for ax, (err, sig, words) in zip(axes, (("east_m", "sigma_east_m", "east error"),
                                            ("north_m", "sigma_north_m", "north error"),
                                            ("up_m", "sigma_up_m", "up error"))):
        value, sigma = table[err].to_numpy(), table[sig].to_numpy()
        sigma_band(ax, t, 0.0, sigma, label=f"±{SIGMA_BAND:g}σ")
        ax.plot(t, value, color="C0", lw=0.9, label="SPP − reference")
        limit_axis(ax, t, value, robust_limit(value, SIGMA_BAND * sigma), "m")
        ax.set_ylabel(f"{words} (m)")
        ax.legend(loc="upper left", fontsize=7, ncols=3)
    ax = axes[3]
    curves = {"horizontal error": (table["horizontal_m"], "C0", "-"),
              "HPL": (table["hpl_m"], "C0", ":"),
              "|up error|": (table["up_m"].abs(), "C2", "-"),
              "VPL": (table["vpl_m"], "C2", ":")}
    for label, (values, colour, style) in curves.items():
        ax.plot(t, values, color=colour, ls=style, lw=0.9, label=label)
    ax.set_yscale("log")         # errors of metres and protection levels of tens of metres
    every = np.concatenate([v.to_numpy(dtype=float) for v, _, _ in curves.values()])
    every = every[np.isfinite(every) & (every > 0.0)]
    if every.size:
        ax.set_ylim(0.7 * every.min(), 1.4 * every.max())
    ax.set_ylabel("error, protection level (m, log)")
    ax.legend(loc="upper left", fontsize=7, ncols=4)


def _sigma_panels(axes, t, table: pd.DataFrame) -> None:
    for ax, (sig, pl, words) in zip(axes, (("sigma_east_m", None, "east"),
                                           ("sigma_north_m", "hpl_m", "north"),
                                           ("sigma_up_m", "vpl_m", "up"))):
        ax.plot(t, table[sig], color="C1", lw=0.9, label=f"1σ {words}")
        if pl is not None:
            ax.plot(t, table[pl], color="C4", lw=0.8, label=pl[:3].upper())
        ax.set_ylim(0.0, robust_limit(table[pl if pl else sig].to_numpy()))
        ax.set_ylabel(f"{words} (m)")
        ax.legend(loc="upper left", fontsize=7, ncols=2)
    axes[3].set_visible(False)


def spp_figure(solution: pd.DataFrame, errors: pd.DataFrame | None = None,
               reference: pd.DataFrame | None = None) -> Figure:
    """The figure (module docstring) of an ``spp.csv`` table and, optionally, its
    `spp_errors` against `reference`."""
    fig = Figure(figsize=(14, 9.5), layout="constrained")
    grid = fig.add_gridspec(5, 2, width_ratios=(1.0, 1.25))
    _map(fig.add_subplot(grid[:, 0]), solution, reference)
    first = fig.add_subplot(grid[0, 1])
    axes = [first] + [fig.add_subplot(grid[k, 1], sharex=first) for k in range(1, 5)]
    t0 = float(solution["gps_time_s"].iloc[0]) if len(solution) else 0.0
    table = solution if errors is None else _with_errors(solution, errors)
    t = table["gps_time_s"].to_numpy() - t0
    no_fix = ~table["fix_ok"].to_numpy(dtype=bool)
    for ax in axes:
        for k in np.flatnonzero(no_fix):
            ax.axvspan(t[k] - 0.5, t[k] + 0.5, **OUTAGE_STYLE)
        plain_axis(ax)
    (_sigma_panels if errors is None else _error_panels)(axes[:4], t, table)
    axes[4].step(t, table["n_sat_tracked"], where="mid", color="0.5", lw=0.9, label="tracked")
    axes[4].step(t, table["n_sat_used"], where="mid", color="C0", lw=1.1, label="used")
    axes[4].set_ylim(0, max(int(np.nanmax(table["n_sat_tracked"], initial=4)) + 2, 6))
    axes[4].set_ylabel("satellites")
    axes[4].set_xlabel(_TIME_LABEL + ("   (grey: epoch without a fix)" if no_fix.any()
                                      else ""))
    axes[4].legend(loc="lower left", fontsize=7, ncols=2)
    fig.suptitle(f"single-point solution: {int((~no_fix).sum())} fixes of {len(table)} epochs")
    return fig
