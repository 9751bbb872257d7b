r"""The status of a network run: the spawn test's, and the rejected-row test of the rows the
navigator reports.

A network run's ``status`` column (`railnav.navigation.network_result`) came from one test
only, `railnav.navigation.spawning`'s: does any live hypothesis agree with the epoch's
position fix horizontally. A navigator that agrees horizontally but uses none of its
measurements passed it: fixes whose heights are ~100 m from the tracks' (a network whose
heights are wrong) had every one of their 270 rows rejected, the hypotheses coasting at
their start speed, while the status said ``ok`` on 86 of 90 epochs
(`tests/railnav/navigation/test_network_status.py`).

The single filter's divergence monitor (`railnav.navigation.monitor`) has a test for
that, the share of rows its gates rejected; this module gives the network run the same
test on the rows it reports: the innovations of the most probable hypothesis at each
epoch (``innovations.csv``, `NetworkResult.innovations`).

**Test.** Over the last `MonitorConfig.window_epochs` epochs with rows, the number of
epochs with at least one row ``rejected`` (``excluded`` rows, a channel kept out after
its rejections, are not counted again) against the binomial law of a fault-free epoch's
rejection: each of its ``m`` rows is rejected with probability at most
``p_row = P(χ²₁ > fault screen's threshold) + (1 − gate_probability)`` (the fault
screen's row test, `railnav.filters.fault_detection.FaultDetectionConfig.nis_threshold`,
1.9e-4 at the defaults, and the navigator's χ² gate, 1e-4; a union bound), so the epoch
with probability at most ``q = 1 − (1 − p_row)^m`` (``m`` the window's largest row count).
Epochs, not rows, are counted: the rows of one fix are rejected together
(`railnav.filters.row_sets.group_status`), so rows are not independent; an epoch's
rejection is ≤ ``q`` whatever the ties. The tail ``p_rejected = P(X ≥ k)``,
``X ~ Binomial(n, q)``, is ``lost`` below `MonitorConfig.p_lost` when at least
`MonitorConfig.lost_rejected_share` of the window's rows were rejected (fewer: the rows,
not the navigator, are bad), ``degraded`` below `MonitorConfig.p_degraded`, else ``ok``:
the single monitor's thresholds and rule.

**Combined.** At each tested time the status is the worse of the two tests' latest
results (``lost`` > ``degraded`` > ``ok``). This test only reports: spawning stays the
spawn test's decision (new hypotheses started from the same fixes would reject the same
rows). The rejected-row test's records are ``p_rejected`` and ``rejected_share`` columns
of the run's monitor frame (``monitor.csv`` is not written for network runs; the
``statistics.monitor`` counts and the estimates' ``status`` are).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.filters.row_sets import ROW_STATUSES
from railnav.navigation.monitor import STATUSES

__all__ = ["row_false_rejection", "rejected_row_records", "combined_status_records"]

Array = npt.NDArray[np.float64]

_REJECTED = ROW_STATUSES[1]


def _at_least(k: Array, n: Array, q: Array) -> Array:
    """``P(X ≥ k)``, ``X ~ Binomial(n, q)``, elementwise (1 where ``k <= 0``)."""
    from scipy.special import bdtrc
    k, n = np.asarray(k, dtype=np.int64), np.asarray(n, dtype=np.int64)
    return np.where(k > 0, bdtrc(np.maximum(k - 1, 0), n, q), 1.0)


def row_false_rejection(config) -> float | None:
    """``p_row`` of the module docstring for a `railnav.config.NavigatorConfig`: the
    probability that a fault-free row is rejected (None: nothing rejects rows)."""
    from scipy.special import chdtrc
    p = 0.0 if config.gate_probability is None else 1.0 - float(config.gate_probability)
    fd = config.fault_detection
    if fd is not None:
        p += float(chdtrc(1.0, float(fd.nis_threshold)))
    return p if p > 0.0 else None


def rejected_row_records(innovations: pd.DataFrame, config) -> pd.DataFrame:
    """The rejected-row test at each epoch of `innovations` (module docstring).

    Parameters
    ----------
    innovations : pandas.DataFrame
        ``innovations.csv`` of the run: ``time_s``, ``epoch``, ``status`` per row.
    config : railnav.config.NavigatorConfig
        Its ``monitor`` thresholds, gate and fault screen.

    Returns
    -------
    pandas.DataFrame
        ``time_s, status, p_rejected, rejected_share``, one row per epoch, in time order
        (empty when nothing rejects rows or there are no rows).
    """
    columns = ["time_s", "status", "p_rejected", "rejected_share"]
    p_row = row_false_rejection(config)
    if p_row is None or len(innovations) == 0:
        return pd.DataFrame(columns=columns)
    rejected = (innovations["status"].to_numpy(dtype=object) == _REJECTED)
    epochs = innovations.assign(rejected=rejected).groupby("epoch", sort=True).agg(
        time_s=("time_s", "first"), rows=("rejected", "size"), rejected=("rejected", "sum"))
    n = int(config.monitor.window_epochs)
    rows = epochs["rows"].rolling(n, min_periods=1)
    bad = epochs["rejected"].rolling(n, min_periods=1)
    q = 1.0 - (1.0 - p_row) ** rows.max().to_numpy(dtype=float)
    k = (epochs["rejected"] > 0).rolling(n, min_periods=1).sum().to_numpy(dtype=float)
    p = _at_least(np.rint(k), np.minimum(np.arange(1, len(epochs) + 1), n), q)
    share = bad.sum().to_numpy(dtype=float) / rows.sum().to_numpy(dtype=float)
    cfg = config.monitor
    status = np.where((p < cfg.p_lost) & (share >= cfg.lost_rejected_share), STATUSES[2],
                      np.where(p < cfg.p_degraded, STATUSES[1], STATUSES[0])).astype(object)
    return pd.DataFrame({"time_s": epochs["time_s"].to_numpy(dtype=float), "status": status,
                         "p_rejected": p, "rejected_share": share})


def combined_status_records(spawn: pd.DataFrame | None, rows: pd.DataFrame) -> pd.DataFrame:
    """The run's status records: `spawn` (`railnav.navigation.spawning.Spawner.frame`)
    and `rows` (`rejected_row_records`) merged on time, each time's status the worse of
    the two tests' latest (module docstring); the columns of both (NaN where a test has no
    record at that time, ``action`` empty)."""
    if spawn is None or len(rows) == 0:
        return spawn
    merged = pd.merge(spawn.rename(columns={"status": "status_fix"}),
                      rows.rename(columns={"status": "status_rows"}),
                      on="time_s", how="outer", sort=True)
    rank = {s: k for k, s in enumerate(STATUSES)}
    worst = np.zeros(len(merged), dtype=int)
    for column in ("status_fix", "status_rows"):
        latest = merged[column].ffill().map(rank).fillna(0).to_numpy(dtype=int)
        worst = np.maximum(worst, latest)
    merged["status"] = np.array(STATUSES, dtype=object)[worst]
    merged["action"] = merged["action"].fillna("")
    return merged.drop(columns=["status_fix", "status_rows"])
