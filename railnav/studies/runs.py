"""The runs of a study: the grid expanded into `RunSpec` s, and one run -> one table row.

`expand_grid` lists every combination of the grid axes times the replicates, in a fixed
order (track, IMU grade, speed, GNSS σ, outages, replicate, then filter innermost, so the
filters of one trip sit side by side). Each run has

* a **seed** derived from the study's seed and the replicate number with
  `numpy.random.SeedSequence` (with ``common_random_numbers = false`` also from the
  run's scenario parameters) — never from the order in which workers pick runs up. The
  filter is not part of it: the filters of a cell are compared on the same simulated
  trip;
* a **run id**: the first 16 hex digits of the SHA-256 of its parameters, seed and the
  track file's content as canonical JSON, stable across processes, machines and Python
  versions (an edited track file gives new ids); resuming a study skips the ids already
  written.

A `RunSpec` carries the track file's text, so workers on other machines need no shared
file system (only this package).

`run_one` simulates and filters one run (`railnav.jobs.run.run_simulated`, or
`railnav.navigation.streaming.stream_simulated` in streaming mode) and returns its row: the
parameters (`RunSpec.parameters`), then the error figures (`metric_columns`), then
``status`` (``"ok"``/``"failed"``), ``error`` (the exception, for a failed run) and
``runtime_s``. A run that raises is recorded as failed, not fatal.
"""
from __future__ import annotations

import functools
import hashlib
import itertools
import json
import logging
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from railnav.simulation.scenarios import get_scenario
from railnav.studies.config import StudyConfig

__all__ = ["RunSpec", "expand_grid", "derive_seed", "run_one", "metric_columns",
           "SUMMARY_QUANTITIES", "OUTAGE_END_QUANTITIES", "STATUS_COLUMNS", "ROW_VERSION"]

log = logging.getLogger(__name__)

#: Part of every run id: bump when the meaning of a row changes, so old rows are not reused.
ROW_VERSION = 1
#: Quantities whose RMS and maximum over the run are columns.
SUMMARY_QUANTITIES = ("along_track_m", "cross_track_m", "vertical_m", "position_3d_m",
                      "speed_mps", "attitude_rad")
#: Quantities whose value at each outage's end is a column (and their maxima in it).
OUTAGE_END_QUANTITIES = SUMMARY_QUANTITIES
#: Columns after the error figures.
STATUS_COLUMNS = ("status", "error", "runtime_s")


@dataclass(frozen=True)
class RunSpec:
    """One run of a study (everything a worker needs; picklable).

    Attributes
    ----------
    index : int
        Position in `expand_grid`'s order.
    run_id : str
    seed : int
    replicate : int
    track : str
        As written in the configuration.
    track_text : str
        The content of its file (`trackmodel.io.parse_track_text`).
    scenario : str
    imu_grade : str
    speed_mps, duration_s : float
    filter : str
    sigma_pseudorange_m, sigma_range_rate_mps : float
    outages : tuple of (start_s, duration_s)
    systems : str
    mode : str
    segment_s : float
    """

    index: int
    run_id: str
    seed: int
    replicate: int
    track: str
    track_text: str = field(repr=False)
    scenario: str
    imu_grade: str
    speed_mps: float
    duration_s: float
    filter: str
    sigma_pseudorange_m: float
    sigma_range_rate_mps: float
    outages: tuple[tuple[float, float], ...]
    systems: str
    mode: str
    segment_s: float

    def parameters(self) -> dict:
        """The parameter columns of the run's row (outages flattened per window)."""
        out = {"run_index": self.index, "run_id": self.run_id, "track": self.track,
               "scenario": self.scenario, "imu_grade": self.imu_grade,
               "speed_mps": self.speed_mps, "duration_s": self.duration_s,
               "filter": self.filter, "sigma_pseudorange_m": self.sigma_pseudorange_m,
               "sigma_range_rate_mps": self.sigma_range_rate_mps, "systems": self.systems,
               "mode": self.mode, "n_outages": len(self.outages)}
        for k, (start, duration) in enumerate(self.outages, start=1):
            out[f"outage{k}_start_s"] = start
            out[f"outage{k}_duration_s"] = duration
        out.update(replicate=self.replicate, seed=self.seed)
        return out


def derive_seed(master_seed: int, replicate: int, words: tuple[int, ...] = ()) -> int:
    """A run's seed (>= 0, < 2**63) from the study seed, the replicate and extra words."""
    state = np.random.SeedSequence([int(master_seed), int(replicate), *words]).generate_state(
        2, np.uint32)
    return int((int(state[0]) << 31) ^ int(state[1]))


def _digest_words(payload: dict) -> tuple[int, ...]:
    digest = hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).digest()
    return tuple(int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4))


def expand_grid(config: StudyConfig) -> list[RunSpec]:
    """Every run of the study, in the module's order (module docstring)."""
    specs = []
    texts = {t: config.track_text(t) for t in config.tracks}
    digests = {t: hashlib.sha256(text.encode()).hexdigest() for t, text in texts.items()}
    axes = itertools.product(config.tracks, config.imu_grades, config.speeds_mps,
                             config.sigma_pseudorange_m, config.sigma_range_rate_mps,
                             config.outage_sets, range(config.replicates), config.filters)
    for index, (track, grade, speed, s_pr, s_rr, outages, rep, kind) in enumerate(axes):
        scene = {"track": track, "scenario": config.scenario, "imu_grade": grade,
                 "speed_mps": float(speed), "duration_s": float(config.duration_s),
                 "sigma_pseudorange_m": float(s_pr), "sigma_range_rate_mps": float(s_rr),
                 "outages": [[float(a), float(b)] for a, b in outages],
                 "systems": config.systems, "mode": config.mode,
                 "segment_s": float(config.segment_s) if config.mode == "streaming" else None}
        words = () if config.common_random_numbers else _digest_words(scene)
        seed = derive_seed(config.seed, rep, words)
        identity = {**scene, "filter": kind, "replicate": rep, "seed": seed,
                    "track_sha256": digests[track], "row_version": ROW_VERSION}
        run_id = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:16]
        specs.append(RunSpec(
            index=index, run_id=run_id, seed=seed, replicate=rep, track=track,
            track_text=texts[track], scenario=config.scenario,
            imu_grade=grade, speed_mps=float(speed), duration_s=float(config.duration_s),
            filter=kind, sigma_pseudorange_m=float(s_pr), sigma_range_rate_mps=float(s_rr),
            outages=tuple((float(a), float(b)) for a, b in outages), systems=config.systems,
            mode=config.mode, segment_s=float(config.segment_s)))
    return specs


def _split_unit(quantity: str) -> tuple[str, str]:
    base, unit = quantity.rsplit("_", 1)
    return base, unit


def metric_columns(n_outages: int) -> list[str]:
    """The error-figure columns of a row with `n_outages` outages, in order."""
    cols = []
    for q in SUMMARY_QUANTITIES:
        base, unit = _split_unit(q)
        cols += [f"{base}_rms_{unit}", f"{base}_max_{unit}"]
    cols += ["nees_mean", "nees_dof", "nis_continuous_mean", "gnss_epochs", "steps",
             "left_track_time_s"]
    for k in range(1, n_outages + 1):
        cols.append(f"outage{k}_end_sample_s")
        for q in OUTAGE_END_QUANTITIES:
            base, unit = _split_unit(q)
            cols += [f"outage{k}_{base}_end_{unit}", f"outage{k}_{base}_max_{unit}"]
    return cols


def _metrics(summary: dict, outages) -> dict:
    """The error figures of a run's ``summary.json`` content."""
    errors = summary["errors"]
    out = {}
    for q in SUMMARY_QUANTITIES:
        base, unit = _split_unit(q)
        out[f"{base}_rms_{unit}"] = _num(errors["all"][q]["rms"])
        out[f"{base}_max_{unit}"] = _num(errors["all"][q]["max"])
    stats = summary["statistics"]
    left = summary.get("left_track")
    out.update(nees_mean=_num(errors["nees"]["mean"]), nees_dof=int(errors["nees"]["dof"]),
               nis_continuous_mean=_num(stats.get("nis_continuous_mean")),
               gnss_epochs=int(stats["gnss_epochs"]), steps=int(summary["steps"]),
               left_track_time_s=_num(left["time_s"]) if left else math.nan)
    ends = {(o["start_s"], o["duration_s"]): o for o in errors["outages"]}
    for k, window in enumerate(outages, start=1):
        found = ends.get(tuple(window))
        out[f"outage{k}_end_sample_s"] = _num(found["end_sample_s"]) if found else math.nan
        for q in OUTAGE_END_QUANTITIES:
            base, unit = _split_unit(q)
            out[f"outage{k}_{base}_end_{unit}"] = _num(found["at_end"][q]) if found else math.nan
            out[f"outage{k}_{base}_max_{unit}"] = _num(found["max"][q]) if found else math.nan
    return out


def _num(value) -> float:
    return math.nan if value is None else float(value)


@functools.lru_cache(maxsize=8)
def _track(text: str, name: str):
    from trackmodel.io import parse_track_text
    return parse_track_text(text, path=name)


def _summary(spec: RunSpec) -> dict:
    """Simulate and filter one run; its ``summary.json`` content."""
    from railnav.jobs.run import run_simulated
    from railnav.navigation.streaming import stream_simulated
    from railnav.simulation.trip import navigator_config_for
    scenario = get_scenario(spec.scenario).with_overrides(speed_mps=spec.speed_mps,
                                                          duration_s=spec.duration_s)
    scenario = replace(scenario, imu_errors=spec.imu_grade, outages=spec.outages,
                       sigma_pseudorange_m=spec.sigma_pseudorange_m,
                       sigma_range_rate_mps=spec.sigma_range_rate_mps)
    config = navigator_config_for(scenario, filter=spec.filter, systems=spec.systems)
    track = _track(spec.track_text, spec.track)
    if spec.mode == "streaming":
        return stream_simulated(track, scenario, config=config, seed=spec.seed,
                                systems=spec.systems, segment_s=spec.segment_s).summary
    return run_simulated(track, scenario, config=config, seed=spec.seed,
                         systems=spec.systems).summary


def _interrupted(exc: BaseException) -> bool:
    """Whether `exc` carries a Ctrl-C: CasADi (like other C extensions) reports a
    KeyboardInterrupt raised inside its callbacks as a SystemError caused by it."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def run_one(spec: RunSpec) -> dict:
    """Run `spec`; its table row (module docstring). Never raises for a failed run."""
    started = time.perf_counter()
    row = spec.parameters()
    metrics = dict.fromkeys(metric_columns(len(spec.outages)), math.nan)
    try:
        metrics.update(_metrics(_summary(spec), spec.outages))
        status, message = "ok", ""
    except Exception as exc:      # noqa: BLE001 - a failed run is a row, not the end
        if _interrupted(exc):
            raise KeyboardInterrupt from None   # Ctrl-C seen through C code: not a failure
        log.warning("run %s (index %d) failed: %s: %s", spec.run_id, spec.index,
                    type(exc).__name__, exc)
        status, message = "failed", f"{type(exc).__name__}: {exc}"
    row.update(metrics)
    row.update(status=status, error=message, runtime_s=time.perf_counter() - started)
    return row
