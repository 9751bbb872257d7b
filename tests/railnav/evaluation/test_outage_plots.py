"""Outage error tables and their plots (railnav/evaluation/outage_plots.py).

References: synthetic runs whose errors are closed forms of the time into the outage
(``a·τ²`` along, ``b·τ`` across), so the table, its medians/percentiles
(`numpy.percentile`, linear interpolation) and the end-of-outage values are known exactly.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from railnav.errors import RailnavError
from railnav.evaluation.outage_plots import (
    errors_at_durations,
    growth_bands,
    outage_errors,
    plot_errors_at_durations,
    plot_outage_growth,
)

#: Output step of the synthetic runs, s (10 Hz, as `railnav.NavigatorConfig`).
STEP_S = 0.1
OUTAGE = (50.0, 30.0)


def _errors(a: float, b: float):
    """An ErrorSeries-like run: along a·τ², cross b·τ inside the outage, 0 outside."""
    t = np.round(np.arange(0.0, 100.0, STEP_S), 6)
    tau = np.where((t >= OUTAGE[0]) & (t < sum(OUTAGE)), t - OUTAGE[0], 0.0)
    along, cross = a * tau ** 2, b * tau
    return SimpleNamespace(time_s=t, along_track_m=along, cross_track_m=cross,
                           vertical_m=np.zeros_like(t), position_3d_m=np.hypot(along, cross))


@pytest.fixture
def table():
    runs = []
    for seed, a in enumerate((0.01, 0.02, 0.03, 0.04)):
        runs.append(outage_errors(_errors(a, 0.0), OUTAGE,
                                  {"imu_grade": "mems", "filter": "constrained", "seed": seed}))
        runs.append(outage_errors(_errors(0.0, -a * 10), OUTAGE,
                                  {"imu_grade": "mems", "filter": "unconstrained",
                                   "seed": seed}))
    return pd.concat(runs, ignore_index=True)


def test_rows_are_the_samples_inside_the_outage(table):
    one = table[(table["filter"] == "constrained") & (table["seed"] == 0)]
    assert len(one) == round(OUTAGE[1] / STEP_S)
    assert one["time_into_outage_s"].iloc[0] == 0.0
    assert one["time_into_outage_s"].iloc[-1] == pytest.approx(OUTAGE[1] - STEP_S)
    np.testing.assert_allclose(one["along_track_m"], 0.01 * one["time_into_outage_s"] ** 2)
    np.testing.assert_allclose(one["horizontal_m"], np.abs(one["along_track_m"]))
    assert list(table.columns[:3]) == ["imu_grade", "filter", "seed"]


def test_bands_are_the_percentiles_over_runs(table):
    bands = growth_bands(table, quantity="horizontal_m", band=0.5)
    row = bands[(bands["filter"] == "unconstrained") & (bands["time_into_outage_s"] == 20.0)]
    values = np.array([0.1, 0.2, 0.3, 0.4]) * 20.0          # |b|·τ of the four runs
    assert row["runs"].item() == 4
    assert row["median"].item() == pytest.approx(np.median(values))
    assert row["low"].item() == pytest.approx(np.percentile(values, 25))
    assert row["high"].item() == pytest.approx(np.percentile(values, 75))


def test_error_at_the_end_of_shorter_outages(table):
    ends = errors_at_durations(table, [10.0, 30.0, 60.0], quantity="along_track_m")
    con = ends[ends["filter"] == "constrained"].set_index("duration_s")
    # the last sample before τ = D is D − 0.1 s; the median of a = 0.01..0.04 is 0.025
    assert con.loc[10.0, "median"] == pytest.approx(0.025 * (10.0 - STEP_S) ** 2)
    assert con.loc[30.0, "median"] == pytest.approx(0.025 * (30.0 - STEP_S) ** 2)
    assert 60.0 not in con.index            # longer than the outages run: no value


def test_plots_have_one_panel_per_grade(table, tmp_path):
    two = pd.concat([table, table.assign(imu_grade="tactical")], ignore_index=True)
    for fig in (plot_outage_growth(two), plot_errors_at_durations(two, [5.0, 10.0, 20.0])):
        assert isinstance(fig, Figure) and len(fig.axes) == 2
        assert [ax.get_title() for ax in fig.axes] == ["mems", "tactical"]
        fig.savefig(tmp_path / "plot.png")
    assert (tmp_path / "plot.png").stat().st_size > 0


def test_unknown_quantity_or_missing_columns_raise(table):
    with pytest.raises(RailnavError, match="quantity must be one of"):
        growth_bands(table, quantity="speed_mps")
    with pytest.raises(RailnavError, match="lacks the columns"):
        growth_bands(table.drop(columns=["filter"]))
