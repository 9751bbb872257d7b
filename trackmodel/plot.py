"""One figure of a track: map view, height profile and curvature profile along s."""
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
    """A matplotlib Figure: map (east/north from the origin, km), h(s) and κ(s)."""
    from matplotlib.figure import Figure

    s = np.linspace(0.0, track.length_m, PLOT_SAMPLES)
    pt = track.at(s)
    o = track.origin
    enu = ecef_to_enu(pt.r_e, lat0=o.lat, lon0=o.lon, h0=o.h, earth=track.earth)
    joints = track.table.s_start[1:]
    fig = Figure(figsize=(11, 7), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1))
    ax = fig.add_subplot(grid[:, 0])
    ax.plot(enu[:, 0] / 1e3, enu[:, 1] / 1e3, lw=1.2)
    jp = track.at(joints) if len(joints) else None
    if jp is not None:
        je = ecef_to_enu(jp.r_e, lat0=o.lat, lon0=o.lon, h0=o.h, earth=track.earth)
        ax.plot(je[:, 0] / 1e3, je[:, 1] / 1e3, ".", ms=3, label="section joints")
        ax.legend(loc="best")
    ax.plot(0, 0, "k^", label="origin")
    ax.set(xlabel="east (km)", ylabel="north (km)", aspect="equal",
           title=title or f"track, {track.length_m / 1e3:.2f} km, {len(track.sections)} sections")
    ax_h = fig.add_subplot(grid[0, 1])
    ax_h.plot(s / 1e3, pt.h)
    ax_h.set(ylabel="height h (m)")
    ax_k = fig.add_subplot(grid[1, 1], sharex=ax_h)
    ax_k.plot(s / 1e3, pt.curvature_1pm * 1e3)
    ax_k.set(xlabel="along-track distance s (km)", ylabel="curvature dA/ds (1/km)")
    for a in (ax_h, ax_k):
        a.grid(alpha=0.3)
    return fig


def plot_track(track: Track, path: str | os.PathLike, *, title: str | None = None) -> None:
    """Write `track_figure` to `path` (PNG/PDF/SVG by extension), atomically."""
    fig = track_figure(track, title=title)
    ext = os.path.splitext(os.fspath(path))[1].lstrip(".") or "png"
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=ext, dpi=120)
