"""railnav/reproduce/common.py: statistics, table and JSON of a result built here by hand.

References: the median and the linearly interpolated 95th percentile of 1, 2, ..., 100
are 50.5 and 95.05 (rank 0.95·99 = 94.05 → between 95 and 96)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.reproduce.common import (
    EXPERIMENTS,
    PaperFigure,
    Quantity,
    ReproductionResult,
    run_experiment,
    write_result_json,
)

EXACT = 1e-12


def _result(**overrides):
    kwargs = dict(
        experiment="toy", runs=100, seed=3,
        quantities=(Quantity("error_m", "error", "m"), Quantity("rate", "rate", "1")),
        variants={"ours": "the method", "baseline": "without it"},
        samples={"ours": {"error_m": np.arange(1.0, 101.0), "rate": np.zeros(100)},
                 "baseline": {"error_m": 10.0 * np.arange(1.0, 101.0)}},
        paper={"ours": {"error_m": PaperFigure(50.0, "below")},
               "baseline": {"error_m": PaperFigure(600.0)}},
        settings={"dt": 0.02}, notes=("a note",))
    kwargs.update(overrides)
    return ReproductionResult(**kwargs)


def test_statistics_median_and_p95():
    median, p95 = _result().statistics("ours", "error_m")
    assert median == pytest.approx(50.5, abs=EXACT)
    assert p95 == pytest.approx(95.05, abs=EXACT)
    assert all(np.isnan(_result().statistics("baseline", "rate")))


def test_table_rows_and_paper_column():
    table = _result().to_table()
    assert list(table.columns) == ["quantity", "unit", "variant", "paper", "median", "p95"]
    assert table[["quantity", "variant", "paper"]].values.tolist() == [
        ["error", "ours", "<50"], ["error", "baseline", "≈600"], ["rate", "ours", ""]]
    assert table["median"].iloc[1] == pytest.approx(505.0, abs=EXACT)
    text = _result().format_table()
    assert text.splitlines()[0] == "toy: 100 Monte Carlo runs, seed 3"
    assert "baseline: without it" in text


def test_json_document(tmp_path):
    path = write_result_json(_result(), tmp_path / "new_dir")
    assert path == tmp_path / "new_dir" / "toy.json"
    doc = json.loads(path.read_text())
    assert doc["paper"]["ours"]["error_m"] == {"value": 50.0, "relation": "below"}
    assert doc["ours"]["error_m"]["median"] == pytest.approx(50.5, abs=EXACT)
    assert doc["ours"]["error_m"]["unit"] == "m"
    assert doc["baseline"]["description"] == "without it"
    assert (doc["runs"], doc["seed"], doc["settings"], doc["notes"]) == \
        (100, 3, {"dt": 0.02}, ["a note"])
    assert [p.name for p in path.parent.iterdir()] == ["toy.json"]   # no temporary left


def test_reserved_variant_name_raises():
    with pytest.raises(ConfigError, match="reserved"):
        _result(variants={"paper": "clash"})


@pytest.mark.parametrize("name, runs, seed", [("nope", 1, 0), ("anomaly2021", 0, 0),
                                              ("anomaly2021", 1, -1)])
def test_run_experiment_bad_arguments(name, runs, seed):
    with pytest.raises(ConfigError):
        run_experiment(name, runs=runs, seed=seed)


def test_registry_entries_load():
    for experiment in EXPERIMENTS.values():
        assert callable(experiment.load())
        assert experiment.default_runs >= 1
