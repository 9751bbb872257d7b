"""What every figure of a run shares: GNSS outage shading, robust axis limits, σ bands, units.

The conventions a reader can rely on in every PNG railnav writes:

* axes are named in words with the unit in parentheses, ``along-track error (m)``; attitude
  errors are in mrad, attitude estimates in degrees; no axis carries a multiplier or an
  offset (``1e-5``);
* time is ``time from the trip start (s)``;
* GNSS outages are shaded grey wherever a time axis is drawn: the declared outages of a
  simulation, and in recorded data the gaps between GNSS epochs longer than
  `GAP_FACTOR` × the usual epoch interval (a legend entry says so; nothing is claimed when
  there is none);
* a ``±3σ`` band is the filter's own uncertainty (`SIGMA_BAND` standard deviations);
* an error axis is scaled to the errors and the typical band (`robust_limit`), not to the
  band's peak (the initial convergence, the end of an outage); a value beyond the axis is
  reported in the panel's corner rather than hidden;
* a time series much longer than its axis is wide in pixels is drawn through the samples
  that set what each pixel column shows (`thin_to_pixels`), computed from every sample
  like the axis limits and the off-scale notes.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["SIGMA_BAND", "GAP_FACTOR", "TIME_LABEL", "OUTAGE_STYLE", "MRAD_PER_RAD",
           "gnss_gaps", "outage_spans", "shade_outages", "robust_limit", "limit_axis",
           "sigma_band", "plain_axis", "save_png", "outage_legend_handle", "fixed_margins",
           "bottom_legend", "PNG_DPI", "THIN_ABOVE_PER_COLUMN", "pixel_columns",
           "thin_to_pixels", "warm_up", "Layout", "laid_out", "lay_out_ahead", "TICKS_AHEAD"]

Array = npt.NDArray[np.float64]

#: Width of the uncertainty bands, in standard deviations.
SIGMA_BAND = 3.0
#: A gap between GNSS epochs longer than this many times their median interval is shaded.
GAP_FACTOR = 2.5
TIME_LABEL = "time from the trip start (s)"
OUTAGE_STYLE = dict(color="0.85", zorder=0, lw=0)
MRAD_PER_RAD = 1e3
#: Percentile of |error| that sets an error axis (the largest 0.5 % may be off scale).
ERROR_PERCENTILE = 99.5
#: Head room above the robust extent of the data.
HEADROOM = 1.25
#: Resolution of the PNG files, dots per inch.
PNG_DPI = 110
#: `thin_to_pixels`: samples kept per pixel column besides the extremes (evenly spaced),
#: and the samples per column beyond which a series is thinned (it must at least halve).
#: Rendered against every sample, a noisy 10-hour series (~430 a column) thinned to ~8 a
#: column differs in as few pixels as thinned to ~22 (16 evenly spaced: 674 and 610 pixels
#: by more than 32 levels of ~330 000; the same mean ink).
KEEP_PER_COLUMN = 2
THIN_ABOVE_PER_COLUMN = 2 * KEEP_PER_COLUMN


def gnss_gaps(epoch_time_s: npt.ArrayLike) -> list[tuple[float, float]]:
    """``(start_s, duration_s)`` of the gaps between GNSS epochs longer than `GAP_FACTOR`
    times the median epoch interval (the outages seen in recorded data)."""
    t = np.unique(np.asarray(epoch_time_s, dtype=float))
    if t.size < 3:
        return []
    step = np.diff(t)
    long_gap = np.flatnonzero(step > GAP_FACTOR * np.median(step))
    return [(float(t[i]), float(step[i])) for i in long_gap]


def outage_spans(result) -> list[tuple[float, float]]:
    """The declared outages of a run and the GNSS gaps of its data that none of them covers
    (``result``: a `railnav.navigation.result.NavigationResult`)."""
    declared = [(float(a), float(d)) for a, d in getattr(result, "outages", ())]
    innovations = getattr(result, "innovations", None)
    found = gnss_gaps(innovations["time_s"]) if innovations is not None and len(
        innovations) else []

    def covered(start: float, duration: float) -> bool:
        return any(a <= start + duration and start <= a + d for a, d in declared)

    return declared + [gap for gap in found if not covered(*gap)]


def shade_outages(ax, spans) -> None:
    """Grey spans on a time axis."""
    for start, duration in spans:
        ax.axvspan(start, start + duration, **OUTAGE_STYLE)


#: Shading of the monitor's non-``ok`` statuses (`railnav.navigation.monitor`) on time axes.
STATUS_STYLE = {"degraded": {"color": "gold", "alpha": 0.25, "lw": 0},
                "lost": {"color": "red", "alpha": 0.2, "lw": 0}}


def status_spans(result) -> dict[str, list[tuple[float, float]]]:
    """(start, duration) of each run of ``degraded`` and ``lost`` rows of the estimates'
    ``status`` column (none without it)."""
    est = getattr(result, "estimates", None)
    if est is None or "status" not in est or not len(est):
        return {}
    t = est["time_s"].to_numpy(dtype=float)
    status = est["status"].to_numpy(dtype=object)
    out: dict[str, list[tuple[float, float]]] = {}
    for name in STATUS_STYLE:
        flag = np.concatenate([[False], status == name, [False]]).astype(int)
        starts = np.flatnonzero(np.diff(flag) == 1)
        stops = np.flatnonzero(np.diff(flag) == -1) - 1
        end = np.append(t[1:], t[-1])          # a row's status holds until the next row
        spans = [(float(t[a]), float(end[b] - t[a])) for a, b in zip(starts, stops)]
        if spans:
            out[name] = spans
    return out


def shade_status(ax, spans: dict) -> None:
    """The `status_spans` on a time axis: one collection per status, however many runs (a
    long trip may have hundreds, each an artist of its own as an ``axvspan``)."""
    for name, runs in spans.items():
        ax.broken_barh(runs, (0.0, 1.0), transform=ax.get_xaxis_transform(),
                       **STATUS_STYLE[name])


def status_legend_handles(spans: dict) -> list:
    """Legend entries for the statuses shaded."""
    from matplotlib.patches import Patch
    return [Patch(color=STATUS_STYLE[n]["color"], alpha=STATUS_STYLE[n]["alpha"] * 2,
                  label=f"monitor: {n}") for n in spans]


def outage_legend_handle():
    """A legend entry for the shading."""
    from matplotlib.patches import Patch
    return Patch(color=OUTAGE_STYLE["color"], label="GNSS outage")


def robust_limit(values: npt.ArrayLike, band: npt.ArrayLike | None = None) -> float:
    """Half-height of a symmetric error axis: `HEADROOM` × the larger of the
    `ERROR_PERCENTILE` th percentile of |values| and the median of `band` (≥ 0)."""
    v = np.abs(np.asarray(values, dtype=float))
    v = v[np.isfinite(v)]
    extent = float(np.percentile(v, ERROR_PERCENTILE)) if v.size else 0.0
    if band is not None:
        b = np.asarray(band, dtype=float)
        b = b[np.isfinite(b)]
        if b.size:
            extent = max(extent, float(np.median(b)))
    return HEADROOM * extent if extent > 0.0 else 1.0


def limit_axis(ax, t: Array, values: Array, limit: float, unit: str) -> None:
    """Set the axis to ±`limit` and say in its corner how far a clipped value reaches."""
    ax.set_ylim(-limit, limit)
    v = np.asarray(values, dtype=float)
    finite = np.isfinite(v)
    if not finite.any():
        return
    k = int(np.nanargmax(np.where(finite, np.abs(v), -np.inf)))
    if abs(v[k]) > limit:
        ax.text(0.995, 0.96, f"off scale: {v[k]:+.3g} {unit} at {t[k]:.0f} s",
                transform=ax.transAxes, ha="right", va="top", fontsize=7, color="C3")


def sigma_band(ax, t: Array, centre: Array | float, sigma: Array, *, label: str | None = None,
               color: str = "C1") -> None:
    """Shade ``centre ± SIGMA_BAND σ``."""
    half = SIGMA_BAND * np.asarray(sigma, dtype=float)
    ax.fill_between(t, centre - half, centre + half, color=color, alpha=0.25, lw=0,
                    label=label)


def plain_axis(ax) -> None:
    """No offset or multiplier on the y axis (values read as printed); a light grid."""
    try:
        ax.ticklabel_format(axis="y", style="plain", useOffset=False)
    except AttributeError:         # a log or categorical axis has no such formatter
        pass
    ax.grid(True, lw=0.3)


def fixed_margins(fig, *, left_in: float = 1.05, right_in: float = 0.2,
                  top_in: float = 0.45, bottom_in: float = 0.85, hspace: float = 0.12,
                  wspace: float | None = None) -> None:
    """Place the subplots with margins given in inches (room for the tick labels and axis
    labels, the suptitle above, a `bottom_legend` below): the figures of a run are laid
    out once instead of by the constrained layout, whose dry-run draw was half of each
    ``savefig`` (0.96 s -> 0.60-0.80 s CPU for a 5-panel figure)."""
    width, height = fig.get_size_inches()
    fig.subplots_adjust(left=left_in / width, right=1.0 - right_in / width,
                        top=1.0 - top_in / height, bottom=bottom_in / height,
                        hspace=hspace, wspace=wspace)


@dataclass(frozen=True)
class Layout:
    """A figure's size (inches) and its grid of axes placed by `fixed_margins`
    (`margins`: its keyword arguments, as pairs); `laid_out` makes it."""

    figsize: tuple[float, float]
    nrows: int
    ncols: int
    sharex: bool = False
    width_ratios: tuple[float, ...] | None = None
    margins: tuple[tuple[str, float], ...] = ()


#: Ticks made on each axis of a figure laid out ahead (`lay_out_ahead`): matplotlib makes
#: them when an axis is first drawn, as many as it shows (a run's figures: at most ~8).
TICKS_AHEAD = 10
#: Figures laid out ahead, by layout: each is used once.
_AHEAD: dict[Layout, list] = {}


def laid_out(layout: Layout):
    """A new figure of `layout`: (figure, ndarray of axes, shape (nrows, ncols)). One laid
    out ahead (`lay_out_ahead`) if there is one, the same objects as made now."""
    ready = _AHEAD.get(layout)
    if ready:
        return ready.pop()
    from matplotlib.figure import Figure
    fig = Figure(figsize=layout.figsize)
    fixed_margins(fig, **dict(layout.margins))
    gridspec = {} if layout.width_ratios is None else {"width_ratios": layout.width_ratios}
    return fig, fig.subplots(layout.nrows, layout.ncols, sharex=layout.sharex,
                             squeeze=False, gridspec_kw=gridspec)


def lay_out_ahead(layouts) -> None:
    """Make a figure of each of `layouts` now, with `TICKS_AHEAD` ticks on each axis, for
    `laid_out` to hand out later: what a process that waits for the data of its figures
    (`railnav.jobs.plot_worker`) can do before they come (~0.035 s of the 1000-s trip's
    ``errors.png``, ~0.02 s of ``track.png``; the PNG files are the same bytes)."""
    for layout in layouts:
        fig, axes = laid_out(layout)
        for ax in axes.flat:
            ax.xaxis.get_major_ticks(TICKS_AHEAD)
            ax.yaxis.get_major_ticks(TICKS_AHEAD)
        _AHEAD.setdefault(layout, []).append((fig, axes))


def bottom_legend(fig, handles, *, ncols: int = 3) -> None:
    """The figure's legend centred at its bottom edge (below the `fixed_margins` axes)."""
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.005),
               fontsize=8, ncols=ncols)


def pixel_columns(ax) -> int:
    """Width of the axes `ax` in pixels of the PNG (`PNG_DPI`)."""
    fig = ax.get_figure()
    return max(1, round(ax.get_position().width * fig.get_figwidth() * PNG_DPI))


def thin_to_pixels(ax, t: npt.ArrayLike, *series: npt.ArrayLike) -> np.ndarray | slice:
    """The samples of a time series to draw on the time axis of `ax`.

    With more than `THIN_ABOVE_PER_COLUMN` samples per pixel column of the PNG, each
    column keeps its first and last sample and, for each of `series`, the samples where
    it is smallest and largest, and the samples on either side of a NaN gap (which breaks
    a line), and every k-th sample for about `KEEP_PER_COLUMN` a column: a line or band
    through them covers in each column the rows it covers through every sample (tested),
    and a noisy series fills its columns as solidly, with ~6-8 points a column instead of
    the 12 the 1000-s trip at 10 Hz puts in each, or the ~400 of a 10-hour trip (Agg's
    time for the 1000-s trip's ``errors.png``: ~0.025 s less of ~0.27 s). The columns
    are the PNG's, so the time limits of `ax` are fixed first where autoscaling would put
    them (the range of `t` widened by the axes' margin). Shorter series are drawn whole
    and the limits left to autoscaling.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        At its final place in the figure (`fixed_margins`).
    t : array_like, shape (N,)
        Sample times, increasing (s).
    *series : array_like, shape (N,)
        The values drawn against `t` (a line, the edges of a band).

    Returns
    -------
    ndarray of int, increasing, or slice
        The indices to draw; ``slice(None)``: all.
    """
    t = np.asarray(t, dtype=float)
    width_px = pixel_columns(ax)
    if t.size <= THIN_ABOVE_PER_COLUMN * width_px or not t[-1] > t[0]:
        return slice(None)
    pad = ax.margins()[0] * (t[-1] - t[0])
    lo, hi = t[0] - pad, t[-1] + pad
    ax.set_xlim(lo, hi)
    box = ax.get_position()
    inch_px = ax.get_figure().get_figwidth() * PNG_DPI       # the PNG's pixels, as Agg's
    column = np.floor(box.x0 * inch_px + (t - lo) * (box.width * inch_px / (hi - lo))
                      ).astype(np.int64)
    first = np.flatnonzero(np.diff(column, prepend=column[0] - 1))   # each column's first
    size = np.diff(np.append(first, t.size))
    keep = [first, first + size - 1, np.arange(0, t.size, max(1, t.size // (
        KEEP_PER_COLUMN * width_px)))]
    for y in series:
        keep += _extremes_and_gaps(np.asarray(y, dtype=float), column, first, size)
    return np.unique(np.concatenate(keep))


def _extremes_and_gaps(y: Array, column: np.ndarray, first: np.ndarray,
                       size: np.ndarray) -> list[np.ndarray]:
    """For `thin_to_pixels`: where `y` is smallest and largest in each pixel column (its
    first such sample; `column` of each sample, `first` sample and `size` of each column),
    and the samples on either side of each NaN gap."""
    gap = np.isnan(y)
    out = []
    for extreme, blank in ((np.minimum, np.inf), (np.maximum, -np.inf)):
        v = np.where(gap, blank, y)
        at = np.flatnonzero(v == np.repeat(extreme.reduceat(v, first), size))
        out.append(at[np.diff(column[at], prepend=column[0] - 1) != 0])
    edge = np.flatnonzero(np.diff(gap))
    return out + [edge, edge + 1]


#: zlib level of the PNG files: the fastest (1) encodes a run's figure in ~0.03 s instead
#: of ~0.045 s (Pillow's default, 6), for files ~10-16 % larger (errors.png of the 1000-s
#: trip 194 kB instead of 168 kB, track.png 115 kB instead of 105 kB); the pixels are the same.
PNG_COMPRESS_LEVEL = 1


def save_png(fig, path: str | os.PathLike, *, dpi: int = PNG_DPI) -> None:
    """Write `fig` to `path` as PNG (`PNG_COMPRESS_LEVEL`), atomically."""
    from trackmodel.files import atomic_write
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=dpi,
                    pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})


def warm_up() -> None:
    """Draw a small figure in memory, for nothing: the first figure a process draws also
    loads the fonts, lays out its first texts and starts the PNG encoder (0.02-0.05 s of
    the ~0.3 s of a run's figure). A process that waits for figures to draw
    (`railnav.jobs.plot_worker`) pays that while it waits. Nothing is written and no
    setting is changed."""
    import io

    from matplotlib.figure import Figure
    fig = Figure(figsize=(2.0, 1.5))
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 1.0], label="estimate")
    ax.fill_between([0.0, 1.0], [-1.0, -1.0], [1.0, 1.0], alpha=0.2)
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("along-track error (m)")
    ax.set_title("warm-up")
    ax.legend(loc="upper left")
    fig.savefig(io.BytesIO(), format="png", dpi=PNG_DPI)
