"""Reproducible experiments of the source papers: a registry and the "ours vs paper" result.

An experiment is a function ``run(*, runs, seed, progress) -> ReproductionResult``: a
seeded, deterministic Monte Carlo of ``runs`` trials whose per-trial figures are compared
with the paper's. :data:`EXPERIMENTS` maps a name (the ``railnav reproduce NAME``
argument) to an :class:`Experiment`; its function is imported only when run, so adding an
experiment is one entry here and a module that returns a :class:`ReproductionResult`.

The comparison reports, for every quantity and variant, the Monte Carlo median and 95th
percentile next to the paper's figure (:meth:`ReproductionResult.to_table`), and is
written as JSON by :func:`write_result_json`: ``{"experiment", "runs", "seed",
"settings", "notes", "paper": {variant: {quantity: {"value", "relation"}}},
<variant>: {quantity: {"median", "p95", "unit"}}, ...}``.
"""
from __future__ import annotations

import importlib
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError
from trackmodel.files import atomic_write_text

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["PaperFigure", "Quantity", "ReproductionResult", "Experiment", "EXPERIMENTS",
           "run_experiment", "write_result_json", "result_path", "PERCENTILE", "DEFAULT_SEED"]

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]

#: The upper percentile reported next to the median.
PERCENTILE = 95.0
#: Top-level JSON keys that a variant may not take.
_RESERVED_KEYS = frozenset({"experiment", "runs", "seed", "settings", "notes", "paper"})
_RELATION_SIGN = {"about": "≈", "below": "<"}


@dataclass(frozen=True)
class PaperFigure:
    """A figure as the paper states it.

    Attributes
    ----------
    value : float
        In the unit of its :class:`Quantity`.
    relation : {"about", "below"}
        The paper says "about value" or "does not exceed value".
    """

    value: float
    relation: Literal["about", "below"] = "about"

    def __str__(self) -> str:
        return f"{_RELATION_SIGN[self.relation]}{self.value:g}"


@dataclass(frozen=True)
class Quantity:
    """One compared figure: key (with unit suffix), human label and unit."""

    key: str
    label: str
    unit: str


@dataclass(frozen=True, eq=False)
class ReproductionResult:
    """Our Monte Carlo figures next to the paper's.

    Attributes
    ----------
    experiment : str
    runs, seed : int
    quantities : tuple of Quantity
        Table row order.
    variants : Mapping[str, str]
        Variant key (a JSON key) -> description, in table order.
    samples : Mapping[str, Mapping[str, ndarray]]
        ``samples[variant][quantity.key]``: one value per run, shape (runs,).
    paper : Mapping[str, Mapping[str, PaperFigure]]
        ``paper[variant][quantity.key]`` where the paper gives one.
    settings : Mapping[str, Any]
        JSON-serializable parameters of the experiment.
    notes : tuple of str
        How the figures were defined (windows, choices where the paper is silent).
    flat_json : bool
        Write the JSON flat: ``paper`` = ``{quantity: value}`` (one paper variant) and
        each variant ``{quantity: median, quantity_p95: p95}``.
    extra : Mapping[str, Any]
        Further JSON-serializable top-level entries (e.g. consistency figures).
    """

    experiment: str
    runs: int
    seed: int
    quantities: tuple[Quantity, ...]
    variants: Mapping[str, str]
    samples: Mapping[str, Mapping[str, Array]]
    paper: Mapping[str, Mapping[str, PaperFigure]]
    settings: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    flat_json: bool = False
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        clash = _RESERVED_KEYS.intersection(self.variants)
        if clash:
            raise ConfigError(f"variant names {sorted(clash)} are reserved JSON keys")

    def statistics(self, variant: str, key: str) -> tuple[float, float]:
        """``(median, 95th percentile)`` of one quantity over the runs (NaN if absent)."""
        values = self.samples.get(variant, {}).get(key)
        if values is None or np.size(values) == 0:
            return math.nan, math.nan
        return float(np.median(values)), float(np.percentile(values, PERCENTILE))

    def to_table(self) -> pd.DataFrame:
        """One row per quantity and variant: ``quantity, unit, variant, paper, median,
        p95`` (``paper`` is the stated figure, e.g. ``"≈140"``, or ``""``)."""
        import pandas as pd  # here: the experiment table is read without pandas (CLI)

        rows = []
        for q in self.quantities:
            for variant in self.variants:
                if q.key not in self.samples.get(variant, {}):
                    continue
                median, p95 = self.statistics(variant, q.key)
                figure = self.paper.get(variant, {}).get(q.key)
                rows.append({"quantity": q.label, "unit": q.unit, "variant": variant,
                             "paper": "" if figure is None else str(figure),
                             "median": median, "p95": p95})
        return pd.DataFrame(rows, columns=["quantity", "unit", "variant", "paper", "median",
                                           "p95"])

    def format_table(self) -> str:
        """The table as text, with a header line and the variant descriptions."""
        head = f"{self.experiment}: {self.runs} Monte Carlo runs, seed {self.seed}"
        legend = [f"  {name}: {text}" for name, text in self.variants.items()]
        body = self.to_table().to_string(index=False, float_format=lambda v: f"{v:.4g}")
        return "\n".join([head, *legend, "", body])

    def to_json_dict(self) -> dict[str, Any]:
        """The JSON document described in the module docstring (or its flat form)."""
        if self.flat_json:
            return self._flat_json_dict()
        units = {q.key: q.unit for q in self.quantities}
        doc: dict[str, Any] = {
            "experiment": self.experiment, "runs": self.runs, "seed": self.seed,
            "settings": dict(self.settings), "notes": list(self.notes),
            "paper": {v: {k: {"value": f.value, "relation": f.relation}
                          for k, f in figs.items()} for v, figs in self.paper.items()}}
        for variant, description in self.variants.items():
            entry: dict[str, Any] = {"description": description}
            for key in self.samples.get(variant, {}):
                median, p95 = self.statistics(variant, key)
                entry[key] = {"median": median, "p95": p95, "unit": units.get(key, "")}
            doc[variant] = entry
        doc.update(self.extra)
        return doc

    def _flat_json_dict(self) -> dict[str, Any]:
        figures: dict[str, float] = {}
        for figs in self.paper.values():
            figures.update({k: f.value for k, f in figs.items()})
        doc: dict[str, Any] = {"experiment": self.experiment, "runs": self.runs,
                               "seed": self.seed, "settings": dict(self.settings),
                               "notes": list(self.notes), "paper": figures,
                               "units": {q.key: q.unit for q in self.quantities}}
        for variant, description in self.variants.items():
            entry: dict[str, Any] = {"description": description}
            for key in self.samples.get(variant, {}):
                entry[key], entry[f"{key}_p95"] = self.statistics(variant, key)
            doc[variant] = entry
        doc.update(self.extra)
        return doc


def result_path(experiment: str, out_dir: str | Path) -> Path:
    """Where `write_result_json` writes an experiment's result."""
    return Path(out_dir) / f"{experiment}.json"


def write_result_json(result: ReproductionResult, out_dir: str | Path) -> Path:
    """Write ``out_dir/<experiment>.json`` atomically (the directory is created)."""
    path = result_path(result.experiment, out_dir)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(result.to_json_dict(), indent=2, allow_nan=True) + "\n")
    return path


@dataclass(frozen=True)
class Experiment:
    """A registered experiment.

    Attributes
    ----------
    name : str
    function : str
        ``"module:function"``; the function takes ``runs, seed, progress`` keywords and
        returns a :class:`ReproductionResult`.
    description : str
    default_runs : int
    """

    name: str
    function: str
    description: str
    default_runs: int

    def load(self) -> Callable[..., ReproductionResult]:
        """Import and return the experiment's function."""
        module, name = self.function.split(":")
        return getattr(importlib.import_module(module), name)


#: The experiments ``railnav reproduce`` knows, by name.
EXPERIMENTS: dict[str, Experiment] = {
    "anomaly2021": Experiment(
        "anomaly2021", "railnav.reproduce.anomaly2021:reproduce_anomaly2021",
        "Ivanov et al. 2021: GNSS jumps of 100 m against the innovation anomaly test",
        default_runs=20),
    "paper2017": Experiment(
        "paper2017", "railnav.reproduce.paper2017:reproduce_paper2017",
        "Dolgiy et al. 2017: track-constrained INS/GNSS, 1000 s at 20 m/s, two 50-s outages",
        default_runs=20),
}


#: Seed of an experiment's Monte Carlo when none is given (``railnav reproduce``'s too).
DEFAULT_SEED = 1


def run_experiment(name: str, *, runs: int | None = None, seed: int = DEFAULT_SEED,
                   progress: Progress | None = None) -> ReproductionResult:
    """Run a registered experiment.

    Parameters
    ----------
    name : str
        A key of :data:`EXPERIMENTS`.
    runs : int, optional
        Monte Carlo runs (>= 1); default the experiment's ``default_runs``.
    seed : int
        Seed of ``numpy.random.default_rng`` (>= 0).
    progress : callable (done, total), optional

    Raises
    ------
    ConfigError
        Unknown experiment, ``runs < 1`` or ``seed < 0``.
    """
    if name not in EXPERIMENTS:
        raise ConfigError(f"unknown experiment {name!r}; known: {', '.join(sorted(EXPERIMENTS))}")
    experiment = EXPERIMENTS[name]
    runs = experiment.default_runs if runs is None else runs
    if runs < 1 or seed < 0:
        raise ConfigError(f"need runs >= 1 and seed >= 0, got runs={runs}, seed={seed}")
    return experiment.load()(runs=runs, seed=seed, progress=progress)
