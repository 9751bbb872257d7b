"""Plots of a navigation run: errors against the truth, estimates with their σ, the map.

Time axes shade the divergence monitor's ``degraded`` (gold) and ``lost`` (red) rows
(`railnav.evaluation.plot_style.status_spans`), under the grey GNSS outages.

* ``errors.png`` (`errors_figure`, with a truth): estimate − truth of each quantity the
  filter has, with its ``±3σ`` band; along-track (or 3-D), cross-track and vertical position
  (m), speed (m/s), yaw, pitch and roll (mrad).
* ``estimates.png`` (`estimates_figure`, without a truth): left, each estimate with its
  ``±3σ`` band — distance along the track (m), speed (m/s), yaw, pitch, roll (deg); right,
  its 1σ in the same unit, so that the growth of the uncertainty is read at a glance.
* ``track.png`` (`track_estimate_figure`, `railnav.evaluation.map_plots`): the map.

Figures are `matplotlib.figure.Figure` s (no global pyplot state, no backend change); the
shared conventions — outage shading, robust axis limits, units — are
`railnav.evaluation.plot_style`.
"""
from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from railnav.evaluation.map_plots import plot_track_estimate, track_estimate_figure
from railnav.evaluation.plot_style import (
    MRAD_PER_RAD,
    SIGMA_BAND,
    TIME_LABEL,
    Layout,
    bottom_legend,
    lay_out_ahead,
    laid_out,
    limit_axis,
    outage_legend_handle,
    outage_spans,
    plain_axis,
    robust_limit,
    save_png,
    shade_outages,
    shade_status,
    sigma_band,
    status_legend_handles,
    status_spans,
    thin_to_pixels,
)

__all__ = ["plot_errors", "plot_estimates", "plot_track_estimate", "errors_figure",
           "estimates_figure", "track_estimate_figure", "SIGMA_BAND", "errors_layout",
           "lay_out_run", "ERROR_PANELS_OF_FILTER"]

_DEG_TO_MRAD = np.pi / 180.0 * MRAD_PER_RAD

#: Error panels: (errors field, σ column of estimates.csv, σ scale to the plot unit, words,
#: unit, scale of the error to the plot unit).
_POSITION = ("along_track_m", "sigma_s_m", 1.0, "along-track error", "m", 1.0)
_ERROR_PANELS = {
    "position_3d_m": ("position_3d_m", None, 1.0, "3-D position error", "m", 1.0),
    "cross_track_m": ("cross_track_m", "sigma_cross_track_m", 1.0, "cross-track error", "m",
                      1.0),
    "vertical_m": ("vertical_m", "sigma_up_m", 1.0, "vertical error", "m", 1.0),
    "speed_mps": ("speed_mps", "sigma_speed_mps", 1.0, "speed error", "m/s", 1.0),
    **{f"{a}_rad": (f"{a}_rad", f"sigma_{a}_deg", _DEG_TO_MRAD, f"{a} error", "mrad",
                    MRAD_PER_RAD) for a in ("yaw", "pitch", "roll")},
}
#: Estimate panels: (column, words, unit).
_ESTIMATE_PANELS = (("s_m", "distance along the track", "m"), ("speed_mps", "speed", "m/s"),
                    ("yaw_deg", "yaw", "deg"), ("pitch_deg", "pitch", "deg"),
                    ("roll_deg", "roll", "deg"))


def plot_errors(errors, result, path: str | os.PathLike) -> None:
    """`errors_figure` written to a PNG file."""
    save_png(errors_figure(errors, result), path)


def plot_estimates(result, path: str | os.PathLike) -> None:
    """`estimates_figure` written to a PNG file."""
    save_png(estimates_figure(result), path)


def _error_panels(est) -> list[tuple]:
    panels = [_POSITION]
    if "sigma_east_m" in est and "sigma_s_m" not in est:   # an unconstrained filter
        panels = [_ERROR_PANELS["position_3d_m"]]
    if "sigma_cross_track_m" in est:   # a filter off the track: its cross and vertical errors
        panels += [_ERROR_PANELS["cross_track_m"], _ERROR_PANELS["vertical_m"]]
    panels.append(_ERROR_PANELS["speed_mps"])
    panels += [_ERROR_PANELS[f"{a}_rad"] for a in ("yaw", "pitch", "roll")
               if f"sigma_{a}_deg" in est]
    return panels


def errors_figure(errors, result) -> Figure:
    """Errors against the truth with the filter's ±3σ bands, GNSS outages shaded.

    Parameters
    ----------
    errors : railnav.evaluation.metrics.ErrorSeries
    result : railnav.navigation.result.NavigationResult

    Returns
    -------
    matplotlib.figure.Figure
    """
    est, t = result.estimates, errors.time_s
    panels = _error_panels(est)
    spans = outage_spans(result)
    statuses = status_spans(result)
    fig, axes = laid_out(errors_layout(len(panels)))
    axes = axes[:, 0]
    for ax, (field, sig_name, sig_scale, words, unit, scale) in zip(axes, panels):
        shade_status(ax, statuses)
        shade_outages(ax, spans)
        value = np.asarray(getattr(errors, field), dtype=float) * scale
        band = None
        if sig_name is not None and sig_name in est:
            band = SIGMA_BAND * est[sig_name].to_numpy() * sig_scale
        shown = thin_to_pixels(ax, t, value, *([] if band is None else [band]))
        if band is not None:
            sigma_band(ax, t[shown], 0.0, band[shown] / SIGMA_BAND,
                       label=f"±{SIGMA_BAND:g}σ of the filter")
        ax.plot(t[shown], value[shown], lw=0.8, color="C0", label="estimate − truth")
        limit_axis(ax, t, value, robust_limit(value, band), unit)
        ax.set_ylabel(f"{words} ({unit})")
        plain_axis(ax)
    handles, _ = axes[0].get_legend_handles_labels()
    if spans:
        handles.append(outage_legend_handle())
    handles += status_legend_handles(statuses)
    fig.suptitle(f"{result.filter} filter: errors against the truth")
    bottom_legend(fig, handles)
    axes[-1].set_xlabel(TIME_LABEL)
    return fig


def errors_layout(n_panels: int) -> Layout:
    """The layout of an ``errors.png`` of `n_panels` panels."""
    return Layout((9, 1.9 * n_panels + 0.8), n_panels, 1, sharex=True)


#: Panels of ``errors.png`` for each filter's estimates (`_error_panels`; tested).
ERROR_PANELS_OF_FILTER = {"constrained": 5, "unconstrained": 7, "gnss-only": 2}


def lay_out_run(filter_name: str, truth: bool) -> None:
    """Lay out ahead (`plot_style.lay_out_ahead`) the figures of a one-track run
    (`railnav.jobs.run_figures.run_figures`) with `filter_name`, as far as they are known before
    it runs: the map, and with a truth the ``errors.png`` of that filter's panels."""
    from railnav.evaluation.map_plots import MAP_LAYOUT
    panels = ERROR_PANELS_OF_FILTER.get(filter_name) if truth else None
    lay_out_ahead([MAP_LAYOUT, *([] if panels is None else [errors_layout(panels)])])


def estimates_figure(result) -> Figure:
    """Estimates with ±3σ bands (left) and their 1σ (right), GNSS outages shaded; for runs
    without a truth.

    Parameters
    ----------
    result : railnav.navigation.result.NavigationResult

    Returns
    -------
    matplotlib.figure.Figure
    """
    est = result.estimates
    t = est["time_s"].to_numpy()
    panels = [p for p in _ESTIMATE_PANELS if p[0] in est]
    spans = outage_spans(result)
    statuses = status_spans(result)
    fig, axes = laid_out(Layout((12, 1.9 * len(panels) + 0.8), len(panels), 2, sharex=True,
                                width_ratios=(1.6, 1.0), margins=(("wspace", 0.25),)))
    for (ax, ax_sigma), (col, words, unit) in zip(axes, panels):
        value = est[col].to_numpy()
        sigma = est.get(f"sigma_{col}")
        for a in (ax, ax_sigma):
            shade_status(a, statuses)
            shade_outages(a, spans)
            plain_axis(a)
        if sigma is not None:
            sigma = sigma.to_numpy()
            shown = thin_to_pixels(ax, t, value, value + SIGMA_BAND * sigma,
                                   value - SIGMA_BAND * sigma, sigma)
            sigma_band(ax, t[shown], value[shown], sigma[shown], label=f"±{SIGMA_BAND:g}σ")
            ax_sigma.plot(t[shown], sigma[shown], lw=0.9, color="C1")
            ax_sigma.set_ylim(0.0, robust_limit(sigma))
            limit_axis_top(ax_sigma, t, sigma, unit)
        else:
            shown = thin_to_pixels(ax, t, value)
        ax.plot(t[shown], value[shown], lw=0.9, color="C0", label="estimate")
        ax.set_ylabel(f"{words} ({unit})")
        ax_sigma.set_ylabel(f"1σ of {words.split(' ')[0]} ({unit})")
    handles, _ = axes[0, 0].get_legend_handles_labels()
    if spans:
        handles.append(outage_legend_handle())
    handles += status_legend_handles(statuses)
    fig.suptitle(f"{result.filter} filter: estimates and their uncertainty")
    bottom_legend(fig, handles)
    for ax in axes[-1]:
        ax.set_xlabel(TIME_LABEL)
    return fig


def limit_axis_top(ax, t, values, unit: str) -> None:
    """Like `plot_style.limit_axis` for a σ axis from 0: report a clipped peak."""
    v = np.asarray(values, dtype=float)
    top = ax.get_ylim()[1]
    if np.isfinite(v).any() and np.nanmax(v) > top:
        k = int(np.nanargmax(v))
        ax.text(0.995, 0.96, f"off scale: {v[k]:.3g} {unit} at {t[k]:.0f} s",
                transform=ax.transAxes, ha="right", va="top", fontsize=7, color="C3")
