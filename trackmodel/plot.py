"""One figure of a track: map view (start and end marked), height and curvature along s."""
from __future__ import annotations

import os

import numpy as np

from trackmodel.earth import ecef_to_enu
from trackmodel.files import atomic_write
from trackmodel.track import Track

__all__ = ["plot_track", "track_figure"]

#: Points per plotted profile (a track is sampled evenly in s).
PLOT_SAMPLES = 4000


def track_figure(track: Track, *, title: str | None = None):
    """A matplotlib Figure: the map (east/north from the origin, km, equal scales, start and
    end marked, section joints dotted) across the top, and h(s) and κ(s) below it."""
    from matplotlib.figure import Figure

    s = np.linspace(0.0, track.length_m, PLOT_SAMPLES)
    pt = track.at(s)
    o = track.origin
    enu = ecef_to_enu(pt.r_e, lat0=o.lat, lon0=o.lon, h0=o.h, earth=track.earth)
    joints = track.table.s_start[1:]
    fig = Figure(figsize=(11, 9), layout="constrained")
    grid = fig.add_gridspec(3, 1, height_ratios=(1.6, 1.0, 1.0))
    ax = fig.add_subplot(grid[0])
    ax.plot(enu[:, 0] / 1e3, enu[:, 1] / 1e3, lw=1.2, label="track")
    if len(joints):
        je = ecef_to_enu(track.at(joints).r_e, lat0=o.lat, lon0=o.lon, h0=o.h,
                         earth=track.earth)
        ax.plot(je[:, 0] / 1e3, je[:, 1] / 1e3, ".", ms=3, label="section joints")
    ax.plot(0.0, 0.0, ">", color="C2", ms=10, mec="k", label="start (s = 0)")
    ax.plot(enu[-1, 0] / 1e3, enu[-1, 1] / 1e3, "s", color="C3", ms=9, mec="k",
            label=f"end (s = {track.length_m / 1e3:.2f} km)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="east of the start (km)", ylabel="north of the start (km)",
           title=title or f"track, {track.length_m / 1e3:.2f} km, {len(track.sections)} "
                          f"sections, earth {track.earth.name}")
    ax.legend(loc="best", fontsize=8)
    ax_h = fig.add_subplot(grid[1])
    ax_h.plot(s / 1e3, pt.h)
    ax_h.set(ylabel="ellipsoidal height h (m)")
    ax_k = fig.add_subplot(grid[2], sharex=ax_h)
    ax_k.plot(s / 1e3, pt.curvature_1pm * 1e3)
    ax_k.set(xlabel="distance along the track s (km)",
             ylabel="curvature dA/ds (1/km, + right)")
    for a in (ax, ax_h, ax_k):
        a.grid(alpha=0.3)
        a.ticklabel_format(axis="y", style="plain", useOffset=False)
    return fig


def plot_track(track: Track, path: str | os.PathLike, *, title: str | None = None) -> None:
    """Write `track_figure` to `path` (PNG/PDF/SVG by extension), atomically."""
    fig = track_figure(track, title=title)
    ext = os.path.splitext(os.fspath(path))[1].lstrip(".") or "png"
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=ext, dpi=120)
