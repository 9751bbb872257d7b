"""The map of a network run (``network.png``): the network, the route, the fixes, and how
sure the navigator was of the netelement over time.

Left, the part of the network the run covered (km from the first estimate): every
netelement in grey, those of the route (`NetworkResult.route_frame`) drawn over them and
coloured by the probability that the train went through them, the fixes (small dots; any
far off the network are included in the view), the estimated path, start (▶) and end (■).
Right, the probability of the most probable netelement at each cycle (top; the netelement
changes are ticked), on a log axis of 1 − p (middle), and the number of live hypotheses
(bottom), on the time axis of `railnav.evaluation.plot_style` (GNSS outages and gaps
shaded).
"""
from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt
from matplotlib import colormaps
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from railnav.evaluation.plot_style import (
    TIME_LABEL,
    outage_legend_handle,
    outage_spans,
    save_png,
    shade_outages,
)
from trackmodel.earth import ecef_to_enu, geodetic_to_ecef

__all__ = ["network_run_figure", "plot_network_run", "MIN_MISS"]

Array = npt.NDArray[np.float64]

#: Floor of the "1 − p" axis.
MIN_MISS = 1e-6
#: Margin around the covered area, m.
VIEW_MARGIN_M = 200.0


def plot_network_run(network, result, path: str | os.PathLike, *, fixes=None,
                     truth=None) -> None:
    """`network_run_figure` written to a PNG file."""
    save_png(network_run_figure(network, result, fixes=fixes, truth=truth), path)


class _Local:
    """East/north (m) at a reference point."""

    def __init__(self, lat: float, lon: float, earth) -> None:
        self.origin = dict(lat0=lat, lon0=lon, h0=0.0, earth=earth)
        self.earth = earth

    def en(self, lat: Array, lon: Array) -> Array:
        r = geodetic_to_ecef(lat, lon, np.zeros_like(lat), earth=self.earth)
        return ecef_to_enu(r, **self.origin)[:, :2]


def _element_en(local: _Local, track) -> Array:
    n = max(2, int(track.length_m // 20.0) + 2)
    lat, lon, _ = track.geodetic(np.linspace(0.0, track.length_m, n))
    return local.en(lat, lon)


def network_run_figure(network, result, *, fixes=None, truth=None) -> Figure:
    """The figure (module docstring).

    Parameters
    ----------
    network : trackmodel.network.Network
    result : railnav.navigation.network_result.NetworkResult
    fixes : gnss_obs.fixes.FixTable, optional
        The run's fix file (its ``table``: ``lat_deg``, ``lon_deg``).
    truth : railnav.simulation.truth.Truth, optional
        A simulated trip's truth (drawn as a dashed line).
    """
    est = result.estimates
    lat, lon = np.radians(est["lat_deg"].to_numpy()), np.radians(est["lon_deg"].to_numpy())
    any_track = next(iter(network.elements.values()))
    local = _Local(float(lat[0]), float(lon[0]), any_track.earth)
    path_en = local.en(lat, lon)
    fix_en = None if fixes is None else local.en(np.radians(fixes.table["lat_deg"].to_numpy()),
                                                 np.radians(fixes.table["lon_deg"].to_numpy()))
    fig = Figure(figsize=(14, 6.5), layout="constrained")
    grid = fig.add_gridspec(3, 2, width_ratios=(1.25, 1.0))
    ax_map = fig.add_subplot(grid[:, 0])
    axes = [fig.add_subplot(grid[k, 1]) for k in range(3)]
    for ax in axes[1:]:
        ax.sharex(axes[0])
    _map(fig, ax_map, network, result, local, path_en, fix_en, truth)
    _probabilities(axes, result)
    route = result.route_frame()
    fig.suptitle(f"{result.config.filter} filter on the network: route of "
                 f"{len(route)} netelements, final probability "
                 f"{result.route_summary()['final_probability']:.4f}")
    return fig


def _map(fig, ax, network, result, local: _Local, path_en: Array, fix_en, truth) -> None:
    km = 1e-3
    shown = [path_en] if fix_en is None else [path_en, fix_en]
    lo = np.min([p.min(axis=0) for p in shown], axis=0) - VIEW_MARGIN_M
    hi = np.max([p.max(axis=0) for p in shown], axis=0) + VIEW_MARGIN_M
    for name, track in network.elements.items():
        line = _element_en(local, track)
        ax.plot(*(line * km).T, color="0.75", lw=1.0, zorder=1)
    route = result.route_frame()
    cmap, norm = colormaps["viridis"], Normalize(0.0, 1.0)
    for row in route.itertuples():
        line = _element_en(local, network.elements[row.netelement])
        ax.plot(*(line * km).T, color=cmap(norm(row.probability)), lw=4.0, zorder=2,
                solid_capstyle="butt")
        mid = line[len(line) // 2] * km
        ax.annotate(row.netelement, mid, fontsize=7, color="0.2", zorder=5)
    fig.colorbar(_scalar_mappable(cmap, norm), ax=ax, shrink=0.7,
                 label="probability that the route passed the netelement")
    if fix_en is not None:
        ax.plot(*(fix_en * km).T, ".", color="C3", ms=1.5, alpha=0.5, zorder=3, label="fixes")
    if truth is not None:
        t_en = local.en(np.asarray(truth.lat), np.asarray(truth.lon))
        ax.plot(*(t_en * km).T, "--", color="k", lw=0.8, zorder=4, label="truth")
    ax.plot(*(path_en * km).T, "-", color="C0", lw=1.0, zorder=4, label="estimate")
    ax.plot(*path_en[0] * km, ">", color="C2", ms=10, mec="k", label="start", zorder=6)
    ax.plot(*path_en[-1] * km, "s", color="C3", ms=9, mec="k", label="end", zorder=6)
    mid, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    ax.set_xlim((mid[0] - half) * km, (mid[0] + half) * km)
    ax.set_ylim((mid[1] - half) * km, (mid[1] + half) * km)
    ax.set_aspect("equal", adjustable="box")
    ax.set(xlabel="east of the first estimate (km)", ylabel="north of the first estimate (km)",
           title="network (grey), route (coloured), fixes and estimate")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)


def _scalar_mappable(cmap, norm):
    from matplotlib.cm import ScalarMappable
    return ScalarMappable(norm=norm, cmap=cmap)


def _probabilities(axes, result) -> None:
    cyc = result.cycles
    t = cyc["time_s"].to_numpy()
    p = cyc["netelement_probability"].to_numpy()
    top, mid, bottom = axes
    top.plot(t, p, lw=1.0, color="C0")
    changes = np.flatnonzero(cyc["netelement"].to_numpy()[1:] != cyc["netelement"].to_numpy()[:-1])
    for k in changes + 1:
        top.axvline(t[k], color="0.6", lw=0.5, ls=":")
    mid.semilogy(t, np.maximum(1.0 - p, MIN_MISS), lw=1.0, color="C0")
    bottom.step(t, cyc["hypotheses"].to_numpy(), where="post", lw=1.0, color="C1")
    spans = outage_spans(result)
    for ax in axes:
        shade_outages(ax, spans)
        ax.grid(True, alpha=0.3)
    top.set_ylabel("probability of the\nmost probable netelement")
    top.set_ylim(-0.02, 1.02)
    if spans:
        top.legend(handles=[outage_legend_handle()], loc="lower right", fontsize=8)
    mid.set_ylabel(f"1 − probability\n(floor {MIN_MISS:g})")
    bottom.set_ylabel("live hypotheses")
    bottom.set_xlabel(TIME_LABEL)
    top.set_title("dotted: the most probable netelement changes", fontsize=9)
