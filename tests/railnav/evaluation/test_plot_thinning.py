"""`railnav.evaluation.plot_style.thin_to_pixels`: a long time series drawn through the
samples it keeps covers the same pixels as drawn whole.

Reference: the same line and band rendered from every sample (Agg at `PNG_DPI`), compared
column by column: the rows each pixel column inks must agree to `TOL_PX` (the line's
antialiased edge), and the columns of a NaN gap must stay empty in both.
"""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from railnav.evaluation.plot_style import (
    PNG_DPI,
    THIN_ABOVE_PER_COLUMN,
    pixel_columns,
    sigma_band,
    thin_to_pixels,
)

#: Rows by which the inked extent of a column may differ: a 0.8-pt line is 1.2 px wide at
#: 110 dpi, and where it turns at a column's extreme sample its stroke reaches past the
#: sample by up to half that width along segments of other slopes than through every
#: sample, and its antialiased edge one row more.
TOL_PX = 3
N_SAMPLES = 200_000     # a 5.5-hour trip at 10 Hz


def _series(rng):
    """An error and its σ over a long trip as a filter gives them (correlated from sample to
    sample: a random walk, and a little white noise), inside the axis limits, with a gap."""
    t = np.linspace(0.0, 20_000.0, N_SAMPLES)
    walk = np.cumsum(rng.standard_normal(N_SAMPLES))
    walk -= np.linspace(walk[0], walk[-1], N_SAMPLES)      # pinned at both ends
    y = 2.0 * np.sin(t / 700.0) + 0.01 * walk + 0.02 * rng.standard_normal(N_SAMPLES)
    y[80_000:81_000] = np.nan                 # a gap: the line breaks there
    sigma = 1.0 + 0.5 * np.sin(t / 900.0) + 0.002 * rng.standard_normal(N_SAMPLES)
    return t, y, sigma


def _axes(t):
    fig = Figure(figsize=(9, 2.5), dpi=PNG_DPI)
    ax = fig.add_axes((0.1, 0.1, 0.85, 0.85))
    ax.set_axis_off()
    ax.set_ylim(-6.0, 6.0)
    return fig, ax


def _ink(fig):
    """(inked, top row, bottom row) of each pixel column of `fig` rendered as the PNG is
    (Agg, `PNG_DPI`): the rows that are not white."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    mask = np.asarray(canvas.buffer_rgba())[:, :, :3].min(axis=2) < 250
    rows = np.arange(mask.shape[0])[:, None]
    top = np.where(mask, rows, mask.shape[0]).min(axis=0)
    bottom = np.where(mask, rows, -1).max(axis=0)
    return mask.any(axis=0), top, bottom


def test_thinned_line_and_band_cover_the_pixels_of_every_sample():
    rng = np.random.default_rng(15)
    t, y, sigma = _series(rng)
    line = lambda ax, k: ax.plot(t[k], y[k], lw=0.8, color="C0")   # noqa: E731
    band = lambda ax, k: sigma_band(ax, t[k], 0.0, sigma[k])       # noqa: E731
    for draw in (line, band):
        full_fig, full_ax = _axes(t)
        draw(full_ax, slice(None))                   # every sample, limits autoscaled
        fig, ax = _axes(t)
        keep = thin_to_pixels(ax, t, y, 3 * sigma, -3 * sigma)
        assert keep.size < N_SAMPLES / 5             # it does thin
        draw(ax, keep)
        assert ax.get_xlim() == full_ax.get_xlim()   # where autoscaling put them
        (full_inked, full_top, full_bottom), (inked, top, bottom) = _ink(full_fig), _ink(fig)
        assert np.array_equal(full_inked, inked)     # the same columns (the gap stays)
        assert np.abs(full_top - top)[inked].max() <= TOL_PX
        assert np.abs(full_bottom - bottom)[inked].max() <= TOL_PX


def test_short_series_are_drawn_whole():
    t = np.arange(200_000, dtype=float)
    fig, ax = _axes(t)
    n = THIN_ABOVE_PER_COLUMN * pixel_columns(ax)
    assert thin_to_pixels(ax, t[:n], np.sin(t[:n])) == slice(None)
    assert ax.get_autoscalex_on()                    # limits left to autoscaling
    kept = thin_to_pixels(ax, t[:n + 1], np.sin(t[:n + 1]))
    assert kept[0] == 0 and kept[-1] == n and np.all(np.diff(kept) > 0)


def test_every_pixel_column_keeps_its_smallest_and_largest_sample():
    """Reference: each sample's pixel column from the axes' own transform (Agg's pixels at
    `PNG_DPI`), and each column's min and max over every sample, found one column at a
    time, at the density of the 1000-s trip (10 Hz, ~12 samples a column)."""
    rng = np.random.default_rng(37)
    t = np.sort(rng.uniform(0.0, 1000.0, 10_000))
    y = np.cumsum(rng.standard_normal(t.size)) + rng.standard_normal(t.size)
    band = 1.0 + rng.uniform(0.0, 0.5, t.size)
    fig, ax = _axes(t)
    keep = thin_to_pixels(ax, t, y, band)
    assert keep.size < t.size * 3 / 4                 # it thins at this density
    column = np.floor(ax.transData.transform(np.column_stack([t, y]))[:, 0]).astype(int)
    kept = np.zeros(t.size, dtype=bool)
    kept[keep] = True
    for c in np.unique(column):
        here = column == c
        for v in (y, band):
            assert v[here & kept].min() == v[here].min()
            assert v[here & kept].max() == v[here].max()
        first, last = np.flatnonzero(here)[[0, -1]]
        assert kept[first] and kept[last]
