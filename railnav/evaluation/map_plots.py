"""The map of a run (``track.png``): where the vehicle went, and how wrong, at two scales.

Left, the overview (km) of the part of the line the run covered: every candidate track (one
for a single-track run), the estimated path coloured by its horizontal error against the
truth — or, without a truth, by its horizontal 1σ — in metres (colour bar), the GNSS
outages as a wide pale band under the path, and start (▶) and end (■) markers.

Right, a zoom at metre scale around the moment that matters most — the largest error (with
a truth) or the largest σ (without): the tracks there (the two lines of a double track 4.5 m
apart are distinct), the estimated positions around that moment, the truth, and at that
moment the estimate joined to the true position, or its ``±3σ`` along the track.
"""
from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from railnav.evaluation.plot_style import (
    SIGMA_BAND,
    Layout,
    laid_out,
    outage_spans,
    save_png,
)
from trackmodel.earth import ecef_to_enu, geodetic_to_ecef

__all__ = ["track_estimate_figure", "plot_track_estimate", "ZOOM_MIN_HALF_WIDTH_M",
           "MAP_LAYOUT"]

Array = npt.NDArray[np.float64]

#: Smallest half-width of the zoom, m.
ZOOM_MIN_HALF_WIDTH_M = 8.0
#: Points of the coloured path at most (the estimates are thinned evenly beyond).
MAX_PATH_POINTS = 4000
#: Share of the run at its start left out when looking for the zoom's moment.
SETTLE_FRACTION = 0.05
_TRACK_COLOURS = ("0.7", "C9", "C8", "C6", "C4")
#: The map's figure: the overview and the zoom side by side.
MAP_LAYOUT = Layout((13, 6.2), 1, 2, width_ratios=(1.45, 1.0), margins=(
    ("left_in", 0.8), ("right_in", 0.3), ("top_in", 0.6), ("bottom_in", 0.6), ("wspace", 0.3)))


def plot_track_estimate(track, result, path: str | os.PathLike, *, truth=None,
                        names=None) -> None:
    """`track_estimate_figure` written to a PNG file."""
    save_png(track_estimate_figure(track, result, truth=truth, names=names), path)


class _Local:
    """East/north/up (m) at the first track's start."""

    def __init__(self, track) -> None:
        start = track.at(0.0)
        self.earth = track.earth
        self.origin = dict(lat0=float(start.lat), lon0=float(start.lon), h0=float(start.h),
                           earth=track.earth)

    def of_degrees(self, lat_deg, lon_deg, h_m) -> Array:
        r = geodetic_to_ecef(np.radians(lat_deg), np.radians(lon_deg), np.asarray(h_m),
                             earth=self.earth)
        return ecef_to_enu(r, **self.origin)

    def of_track(self, track, s: Array) -> Array:
        return ecef_to_enu(track.at(s).r_e, **self.origin)


def _truth_en(local: _Local, truth, t: Array) -> Array | None:
    if truth is None:
        return None
    en = local.of_degrees(np.degrees(truth.lat), np.degrees(truth.lon), truth.h)[:, :2]
    return np.column_stack([np.interp(t, truth.time_s, en[:, i]) for i in range(2)])


def _colour_values(est, est_en: Array, truth_en: Array | None) -> tuple[Array, str]:
    if truth_en is not None:
        return np.hypot(*(est_en - truth_en).T), "horizontal error (m)"
    if {"sigma_east_m", "sigma_north_m"} <= set(est.columns):
        return np.hypot(est["sigma_east_m"], est["sigma_north_m"]).to_numpy(), \
            "horizontal 1σ (m)"
    return est["sigma_s_m"].to_numpy(), "along-track 1σ (m)"


def track_estimate_figure(track, result, *, truth=None, names=None) -> Figure:
    """The map (module docstring).

    Parameters
    ----------
    track : trackmodel.Track or sequence of Track
        The track, or every candidate track of a multi-track run (the first is drawn first).
    result : railnav.navigation.result.NavigationResult
    truth : railnav.simulation.truth.Truth, optional
        Its ``time_s``, ``lat``, ``lon`` and ``h`` are read (`railnav.jobs.run_figures.TruthPath`).
    names : sequence of str, optional
        The tracks' names for the legend.

    Returns
    -------
    matplotlib.figure.Figure
    """
    tracks = list(track) if isinstance(track, (list, tuple)) else [track]
    names = list(names) if names is not None else [f"track {k + 1}" if len(tracks) > 1
                                                    else "track" for k in range(len(tracks))]
    local = _Local(tracks[0])
    est = result.estimates
    t = est["time_s"].to_numpy()
    est_en = local.of_degrees(est["lat_deg"].to_numpy(), est["lon_deg"].to_numpy(),
                              est["h_m"].to_numpy())[:, :2]
    truth_en = _truth_en(local, truth, t)
    colour, colour_label = _colour_values(est, est_en, truth_en)
    fig, axes = laid_out(MAP_LAYOUT)
    ax_map, ax_zoom = axes[0]
    _overview(fig, ax_map, tracks, names, local, result, est_en, colour, colour_label)
    k = _worst(t, colour)
    _zoom(ax_zoom, tracks, names, local, est, est_en, truth_en, k)
    kind = "error" if truth_en is not None else "uncertainty"
    fig.suptitle(f"{result.filter} filter on the track: path coloured by its {kind}; right, "
                 f"the largest {kind} at t = {t[k]:.1f} s at metre scale")
    return fig


def _worst(t: Array, values: Array) -> int:
    """Index of the largest value after the first `SETTLE_FRACTION` of the run (the
    initial convergence is not the moment a reader looks for); the last if none is finite."""
    later = np.where(t >= t[0] + SETTLE_FRACTION * (t[-1] - t[0]), values, np.nan)
    return int(np.nanargmax(later)) if np.isfinite(later).any() else len(t) - 1


def _overview(fig, ax, tracks, names, local: _Local, result, est_en: Array, colour: Array,
              colour_label: str) -> None:
    km = 1e-3
    lo, hi = est_en.min(axis=0), est_en.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    half += max(0.15 * half, 300.0)
    for j, (trk, name) in enumerate(zip(tracks, names)):
        line = local.of_track(trk, np.linspace(0.0, trk.length_m, 3000))
        ax.plot(line[:, 0] * km, line[:, 1] * km, color=_TRACK_COLOURS[j % 5],
                lw=max(6.0 - 2.0 * j, 1.5), label=name, zorder=1)
    t = result.estimates["time_s"].to_numpy()
    for n, (start, duration) in enumerate(outage_spans(result)):
        m = (t >= start) & (t <= start + duration)
        ax.plot(est_en[m, 0] * km, est_en[m, 1] * km, color="0.8", lw=12, alpha=0.8,
                solid_capstyle="butt", zorder=0, label="GNSS outage" if n == 0 else None)
    step = max(1, len(est_en) // MAX_PATH_POINTS)
    pts = est_en[::step] * km
    segments = np.stack([pts[:-1], pts[1:]], axis=1)
    path = LineCollection(segments, cmap="viridis", lw=2.2, zorder=2)
    path.set_array(colour[::step][:-1])
    ax.add_collection(path)
    fig.colorbar(path, ax=ax, label=colour_label, shrink=0.8)
    ax.plot(*est_en[0] * km, ">", color="C2", ms=10, mec="k", label="start", zorder=3)
    ax.plot(*est_en[-1] * km, "s", color="C3", ms=9, mec="k", label="end", zorder=3)
    ax.set_xlim((mid[0] - half) * km, (mid[0] + half) * km)
    ax.set_ylim((mid[1] - half) * km, (mid[1] + half) * km)
    ax.set_aspect("equal", adjustable="box")
    ax.set(xlabel="east of the track start (km)", ylabel="north of the track start (km)",
           title="overview")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)


def _zoom(ax, tracks, names, local: _Local, est, est_en: Array, truth_en: Array | None,
          k: int) -> None:
    centre = est_en[k] if truth_en is None else 0.5 * (est_en[k] + truth_en[k])
    reach = 0.0 if truth_en is None else float(np.hypot(*(est_en[k] - truth_en[k])))
    sigma_s = float(est["sigma_s_m"].iloc[k]) if "sigma_s_m" in est else float(
        np.hypot(est["sigma_east_m"].iloc[k], est["sigma_north_m"].iloc[k]))
    half = max(ZOOM_MIN_HALF_WIDTH_M, 1.5 * reach, 1.3 * SIGMA_BAND * sigma_s)
    for j, (trk, name) in enumerate(zip(tracks, names)):
        lat, lon = _lat_lon(local, centre)
        near_s = float(np.ravel(trk.project(np.array([lat]), np.array([lon])).s)[0])
        s = np.clip(near_s + np.linspace(-3 * half, 3 * half, 600), 0.0, trk.length_m)
        line = local.of_track(trk, s)[:, :2] - centre
        ax.plot(*line.T, color=_TRACK_COLOURS[j % 5], lw=3.0 - 0.5 * j, label=name)
    window = np.all(np.abs(est_en - centre) < 1.5 * half, axis=1)
    ax.plot(*(est_en[window] - centre).T, ".", color="C0", ms=3, label="estimate")
    if truth_en is not None:
        ax.plot(*(truth_en[window] - centre).T, "--", color="k", lw=0.8, label="truth")
        ax.plot(*np.array([est_en[k], truth_en[k]]).T - centre[:, None], "-", color="C3",
                lw=1.5, label=f"error {reach:.2f} m")
        ax.plot(*(truth_en[k] - centre), "o", color="k", ms=6)
    elif "sigma_s_m" in est:
        trk = tracks[0]
        s_k = float(est["s_m"].iloc[k])
        s = np.clip(s_k + SIGMA_BAND * sigma_s * np.linspace(-1, 1, 50), 0.0, trk.length_m)
        ax.plot(*(local.of_track(trk, s)[:, :2] - centre).T, color="C1", lw=6, alpha=0.6,
                label=f"±{SIGMA_BAND:g}σ along the track ({SIGMA_BAND * sigma_s:.2f} m)")
    ax.plot(*(est_en[k] - centre), "o", color="C0", ms=7, mec="k")
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal", adjustable="box")
    ax.set(xlabel="east of the zoom's centre (m)", ylabel="north of the zoom's centre (m)",
           title=f"zoom at t = {est['time_s'].iloc[k]:.1f} s, ±{half:.0f} m")
    ax.grid(True, lw=0.3)
    ax.legend(loc="upper left", fontsize=8)


def _lat_lon(local: _Local, en: Array) -> tuple[float, float]:
    """Geodetic latitude and longitude (rad) of a local east/north point (at height 0 up)."""
    from trackmodel.earth import ecef_to_geodetic, enu_to_ecef
    r = enu_to_ecef(np.array([en[0], en[1], 0.0]), **local.origin)
    lat, lon, _ = ecef_to_geodetic(r, earth=local.earth)
    return float(lat), float(lon)
