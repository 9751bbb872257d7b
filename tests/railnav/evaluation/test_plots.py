"""Plots a navigation engineer trusts (issue 18): outages shaded where they are mentioned,
σ bands, attitude in mrad, axes in words with units, robust limits, both tracks on the map.

The figures are built from small hand-made results (no filter run), so that each check
compares what is drawn with what was put in: the shaded spans with the gaps written into the
innovations, the plotted attitude error with the error in rad × 1000, the axis limit with
the error's size, not the σ peak.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import LineCollection

from railnav.evaluation.map_plots import track_estimate_figure
from railnav.evaluation.plot_style import (
    GAP_FACTOR,
    MRAD_PER_RAD,
    gnss_gaps,
    outage_spans,
    robust_limit,
)
from railnav.evaluation.plots import errors_figure, estimates_figure
from railnav.evaluation.spp_plots import spp_figure
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

N = 601                                   # 60 s at 10 Hz
T = np.linspace(0.0, 60.0, N)
UNIT = re.compile(r"\((m|m/s|mrad|deg|s)(,[^)]*)?\)$")


@dataclass
class FakeResult:
    """What the figures read of a `NavigationResult`."""

    estimates: pd.DataFrame
    innovations: pd.DataFrame
    outages: tuple = ()
    filter: str = "constrained"


@dataclass
class FakeErrors:
    time_s: np.ndarray
    along_track_m: np.ndarray
    speed_mps: np.ndarray
    yaw_rad: np.ndarray
    pitch_rad: np.ndarray
    roll_rad: np.ndarray
    extra: dict = field(default_factory=dict)


def _track() -> Track:
    return Track([Section(2000.0, 45.0, 0.0)], Origin(48.0, 11.0, 500.0))


def _result(track: Track, *, gap=(20.0, 10.0)) -> FakeResult:
    s = 20.0 * T
    pt = track.at(s)
    est = pd.DataFrame({"time_s": T, "gps_time_s": T + 1e9, "s_m": s,
                        "lat_deg": np.degrees(pt.lat), "lon_deg": np.degrees(pt.lon),
                        "h_m": pt.h, "speed_mps": np.full(N, 20.0), "yaw_deg": 45.0,
                        "pitch_deg": 0.0, "roll_deg": 0.0, "sigma_s_m": 1.0 + 0.1 * T,
                        "sigma_east_m": 0.7, "sigma_north_m": 0.7, "sigma_speed_mps": 0.05,
                        "sigma_yaw_deg": 0.05, "sigma_pitch_deg": 0.02, "sigma_roll_deg": 0.02})
    epochs = np.arange(0.0, 61.0)
    epochs = epochs[(epochs <= gap[0]) | (epochs >= gap[0] + gap[1])]
    inn = pd.DataFrame({"time_s": np.repeat(epochs, 3)})
    return FakeResult(est, inn)


def _spans(ax) -> list[tuple[float, float]]:
    """x extents of the axis' shaded vertical spans (axvspan rectangles)."""
    out = []
    for patch in ax.patches:
        x = patch.get_x() if hasattr(patch, "get_x") else None
        if x is not None:
            out.append((round(x, 6), round(x + patch.get_width(), 6)))
    return out


def test_gnss_gaps_are_the_long_intervals_between_epochs():
    epochs = np.concatenate([np.arange(0.0, 10.0), np.arange(15.0, 21.0), [20.0 + GAP_FACTOR]])
    assert gnss_gaps(epochs) == [(9.0, 6.0)]          # 20 → 22.5 is not longer than the factor


def test_issue18_estimates_png_shades_the_outage_it_mentions():
    """estimates.png said '(grey: GNSS outage)' and shaded nothing: a recorded run has no
    declared outage, so the gap in its GNSS epochs is the outage."""
    result = _result(_track())
    assert outage_spans(result) == [(20.0, 10.0)]
    fig = estimates_figure(result)
    for ax in fig.axes:
        assert (20.0, 30.0) in _spans(ax)
    legend = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
    assert "GNSS outage" in legend and "±3σ" in legend


def test_issue18_axes_are_words_with_units():
    result = _result(_track())
    errors = FakeErrors(T, np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(N))
    for fig in (estimates_figure(result), errors_figure(errors, result)):
        for ax in fig.axes:
            label = ax.get_ylabel()
            assert UNIT.search(label), label
            assert "_" not in label                    # never a raw column name
        assert fig.axes[-1].get_xlabel() == "time from the trip start (s)"


def test_issue18_attitude_errors_in_mrad_and_limits_follow_the_errors():
    result = _result(_track())
    rng = np.random.default_rng(18)
    yaw_rad = 2e-4 * rng.standard_normal(N)
    along = 0.5 * rng.standard_normal(N)
    result.estimates["sigma_s_m"] = np.where(T < 2.0, 500.0, 1.0)   # an initial σ peak
    errors = FakeErrors(T, along, np.zeros(N), yaw_rad, np.zeros(N), np.zeros(N))
    fig = errors_figure(errors, result)
    yaw_ax = next(ax for ax in fig.axes if ax.get_ylabel() == "yaw error (mrad)")
    line = next(ln for ln in yaw_ax.get_lines() if ln.get_label() == "estimate − truth")
    np.testing.assert_allclose(line.get_ydata(), yaw_rad * MRAD_PER_RAD, rtol=1e-15)
    along_ax = fig.axes[0]
    top = along_ax.get_ylim()[1]
    assert top < 10.0 < 3 * 500.0                 # not autoscaled to the 1500-m band
    assert top >= np.abs(along).max()             # every error of this run is in view
    assert top == pytest.approx(robust_limit(along, 3.0 * result.estimates["sigma_s_m"]))


def test_issue18_two_track_map_draws_both_tracks_and_marks_start_and_end():
    track_a = _track()
    track_b = Track([Section(2000.0, 45.0, 0.0)], Origin(48.0, 11.00006, 500.0))   # ~4.5 m east
    result = _result(track_a)
    fig = track_estimate_figure([track_a, track_b], result, names=["double_a", "double_b"])
    overview = next(ax for ax in fig.axes if ax.get_title() == "overview")
    zoom = next(ax for ax in fig.axes if ax.get_title().startswith("zoom"))
    for ax in (overview, zoom):
        labels = [ln.get_label() for ln in ax.get_lines()]
        assert "double_a" in labels and "double_b" in labels
    assert {"start", "end"} <= {ln.get_label() for ln in overview.get_lines()}
    path = [c for c in overview.collections if isinstance(c, LineCollection)][0]
    np.testing.assert_allclose(path.get_array(), np.hypot(0.7, 0.7))  # 1σ: no truth
    half = zoom.get_xlim()[1]
    assert half < 50.0                            # metre scale: the two lines are apart


def test_issue18_spp_plot_has_sigma_bands_protection_levels_and_satellites():
    n = 30
    sol = pd.DataFrame({"gps_time_s": 1e9 + np.arange(n), "lat_deg": 41.6 + 1e-6 * np.arange(n),
                        "lon_deg": 2.35, "h_m": 250.0, "sigma_east_m": 1.0,
                        "sigma_north_m": 1.5, "sigma_up_m": 3.0, "hpl_m": 12.0, "vpl_m": 20.0,
                        "n_sat_tracked": 12, "n_sat_used": 10, "fix_ok": True})
    sol.loc[7, "fix_ok"] = False
    err = pd.DataFrame({"gps_time_s": sol["gps_time_s"], "east_m": 0.5, "north_m": -0.5,
                        "up_m": 2.0, "horizontal_m": np.hypot(0.5, 0.5),
                        "speed_error_mps": np.nan})
    fig = spp_figure(sol, err, sol[["gps_time_s", "lat_deg", "lon_deg", "h_m"]])
    labels = {ax.get_ylabel() for ax in fig.axes}
    assert {"east error (m)", "north error (m)", "up error (m)", "satellites"} <= labels
    east = next(ax for ax in fig.axes if ax.get_ylabel() == "east error (m)")
    band = east.collections[0].get_paths()[0].vertices[:, 1]
    assert band.max() == pytest.approx(3.0 * 1.0) and band.min() == pytest.approx(-3.0)
    pl_ax = next(ax for ax in fig.axes if ax.get_ylabel().startswith("error, protection"))
    assert {"HPL", "VPL"} <= {ln.get_label() for ln in pl_ax.get_lines()}
    assert (6.5, 7.5) in _spans(east)             # the epoch without a fix


def test_fixed_layout_keeps_labels_and_legend_inside_and_apart():
    """The run's figures are laid out with fixed margins (`plot_style.fixed_margins`), not by
    the constrained layout: drawn, every axis label and tick label lies inside the figure,
    and the legend lies below the bottom axis' labels (reference: the drawn extents, from
    the Agg renderer; 1 px of slack)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    result = _result(_track())
    rng = np.random.default_rng(3)
    errors = FakeErrors(T, *(5e-3 * rng.standard_normal(N) for _ in range(5)))
    for fig in (estimates_figure(result), errors_figure(errors, result),
                track_estimate_figure(_track(), result)):
        FigureCanvasAgg(fig).draw()
        renderer = fig.canvas.get_renderer()
        page = fig.bbox
        for ax in fig.axes:
            for text in [ax.yaxis.label, ax.xaxis.label, *ax.get_yticklabels()]:
                if text.get_text():
                    box = text.get_window_extent(renderer)
                    assert box.x0 >= page.x0 - 1 and box.x1 <= page.x1 + 1, text.get_text()
                    assert box.y0 >= page.y0 - 1 and box.y1 <= page.y1 + 1, text.get_text()
        for legend in fig.legends:
            lowest = min(ax.get_tightbbox(renderer).y0 for ax in fig.axes)
            assert legend.get_window_extent(renderer).y1 <= lowest + 1
