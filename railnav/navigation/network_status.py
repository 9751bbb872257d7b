"""The status of a network run: the spawn test's, two tests of the rows the navigator
reports, and one of its pseudo-observation.

A network run's ``status`` column (`railnav.navigation.network_result`) came from one test
only, `railnav.navigation.spawning`'s: does any live hypothesis agree with the epoch's
position fix horizontally. A navigator that agrees horizontally but uses none of its
measurements passed it: fixes whose heights are ~100 m from the tracks' (a network whose
heights are wrong) had every one of their 270 rows rejected, the hypotheses coasting at
their start speed, while the status said ``ok`` on 86 of 90 epochs
(`tests/railnav/navigation/test_network_status.py`).

The single filter's divergence monitor (`railnav.navigation.monitor`) also tests the rows
its gates rejected, the NIS of those it used and its pseudo-observation's NIS; this module
gives the network run the same tests of what it reports: the rows of the most probable
hypothesis at each epoch (``innovations.csv``, `NetworkResult.innovations`), over the last
`MonitorConfig.window_epochs` epochs with rows, and that hypothesis's pseudo-observation.

**Rejected rows.** The number of epochs with at least one row ``rejected`` (``excluded``
rows, a channel kept out after its rejections, are not counted again) against the
binomial law of a fault-free epoch's rejection: each of its ``m`` rows is rejected with
probability at most ``p_row = P(χ²₁ > fault screen's threshold) + (1 − gate_probability)``
(the fault screen's row test, `railnav.filters.fault_config.FaultDetectionConfig.
nis_threshold`, 1.9e-4 at the defaults, and the navigator's χ² gate, 1e-4; a union
bound), so the epoch with probability at most ``q = 1 − (1 − p_row)^m`` (``m`` the
window's largest row count). Epochs, not rows, are counted: the rows of one fix are
rejected together (`railnav.filters.row_sets.group_status`), so rows are not independent;
an epoch's rejection is ≤ ``q`` whatever the ties. The tail ``p_rejected = P(X ≥ k)``,
``X ~ Binomial(n, q)``, is ``lost`` below `MonitorConfig.p_lost` when at least
`MonitorConfig.lost_rejected_share` of the window's rows were rejected (fewer: the rows,
not the navigator, are bad), ``degraded`` below `MonitorConfig.p_degraded`: the single
monitor's thresholds and rule. Epochs whose fix no position on the network explains
(`railnav.navigation.spawning.Spawner`'s ``fix_off_network``) are rejected whatever the
hypotheses: they count for ``degraded`` only, as the single monitor's fixes off the track
(issue 14: log_28554's fixes drifting 20-37 m from every element in the airport tunnel
ended the run ``lost``, 70 epochs; log_29083's receiver jumps, 341 of 874).

**NIS.** The sum of the used rows' ``ν²/S`` against χ² with one degree of freedom per row
(``p_nis``, its upper tail): ``degraded`` below `MonitorConfig.p_degraded`, as the single
monitor's GNSS NIS test. The used rows passed the gates, so a gross error shows in the
rejected rows, a slow one (σ too small for the data) here.

**Pseudo-observation NIS** (inertial runs). The sum over the cycles of the window of the
most probable hypothesis's continuous pseudo-observation NIS, ``Σ νᵀ S⁻¹ ν`` over each
cycle's steps (`pseudo_nis`), against χ² with two degrees of freedom per step
(``p_pseudo_nis``): ``degraded`` below `MonitorConfig.p_degraded`, as the single monitor's
pseudo-observation test; the window is the last `MonitorConfig.window_epochs` cycles (a
cycle ends at each epoch, at a joint, or after `railnav.navigation.loop.MAX_CHUNK_S`).

**Combined.** At each tested time the status is the worst of the tests' latest results
(``lost`` > ``degraded`` > ``ok``). These tests only report: spawning stays the spawn
test's decision (new hypotheses started from the same fixes would reject the same rows).
Their records are the ``p_rejected``, ``rejected_share``, ``p_nis`` and ``p_pseudo_nis``
columns of the run's monitor frame (``monitor.csv`` is not written for network runs; the
``statistics.monitor`` counts and the estimates' ``status`` are).

Measured (load ~2): on the simulated switch runs (`benchmarks/bench_network_switches.py`'s
10 seeds × 448 epochs, pseudoranges and a tactical IMU, 11 rows rejected of ~62 000) the
rejected-row test never fires and the NIS test once (2.2e-4 per epoch, below
``p_degraded``); the pseudo-observation test flags 6 epochs beyond the first four of each
run (0.13 %). It flagged 43 (0.96 %) at the curvature steps of turnouts' reverse curves
until the track parameter grid (`railnav.filters.track_grid`) had a node each side of
each horizontal curvature step: before, a sample whose nearest 0.5-m node lay across the
step took the other side's curvature (seed 3: 13 → 1 flagged epochs, seed 7: 11 → 1).
Since the simulated IMU's interval means and their blend at the steps
(`railnav.filters.geometry_noise`, "Interval means"): 14 (0.31 %), 10 of them one event of
seed 9, a hypothesis whose ``s`` the blend at one step left at z −4 and that the next step's
straddling sample found out (`docs/consistency-ablations.md`, stop 33, s33alarm).

On the Brussels logs as given (fixes only), the status counts (``ok/degraded/lost``
estimate rows) before → after these tests: log_28554
495/72/47 → 485/59/70 (86 of 1210 rows rejected), log_28876 1130/4/0 → 1117/17/0 (the NIS
test), log_29083 489/242/150 → 459/78/344 (590 of 1748 rows rejected: fixes 100-180 m
off the track, "dirty" in the data's README), log_29304 unchanged 904/4/0. With fixes off
the network counted for ``degraded`` only (issue 14; the estimates, rows and route
unchanged): log_28554 485/127/2 (it no longer ends ``lost``), log_29083 459/422/0, the
other two unchanged.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.filters.row_sets import ROW_STATUSES
from railnav.navigation.statuses import STATUSES
from railnav.navigation.tail_probabilities import binom_sf, chi2_sf, row_false_rejection_p

__all__ = ["row_false_rejection", "row_records", "pseudo_nis", "pseudo_records",
           "combined_status_records"]

Array = npt.NDArray[np.float64]

_REJECTED = ROW_STATUSES[1]


def row_false_rejection(config) -> float | None:
    """``p_row`` of the module docstring for a `railnav.config.NavigatorConfig`: the
    probability that a fault-free row is rejected (None: nothing rejects rows, and the
    rejected-row test is off; `tail_probabilities.row_false_rejection_p`)."""
    fd = config.fault_detection
    return row_false_rejection_p(config.gate_probability,
                                 None if fd is None else fd.nis_threshold)


def row_records(innovations: pd.DataFrame, config, off_network=None) -> pd.DataFrame:
    """The row tests at each epoch of `innovations` (module docstring).

    Parameters
    ----------
    innovations : pandas.DataFrame
        ``innovations.csv`` of the run: ``time_s``, ``epoch``, ``nis``, ``status`` per row.
    config : railnav.config.NavigatorConfig
        Its ``monitor`` thresholds, gate and fault screen.
    off_network : array of float, optional
        Times of the epochs whose fix no position on the network explains
        (`railnav.navigation.spawning.Spawner.frame`'s ``fix_off_network``): rejected
        whatever the hypotheses, they count for ``degraded`` only.

    Returns
    -------
    pandas.DataFrame
        ``time_s, status, p_rejected, rejected_share, p_nis``, one row per epoch, in time
        order (empty without rows).
    """
    columns = ["time_s", "status", "p_rejected", "rejected_share", "p_nis"]
    if len(innovations) == 0:
        return pd.DataFrame(columns=columns)
    status = innovations["status"].to_numpy(dtype=object)
    used = status == ROW_STATUSES[0]
    epochs = innovations.assign(
        rejected=status == _REJECTED, used=used,
        used_nis=np.where(used, innovations["nis"].to_numpy(dtype=float), 0.0)).groupby(
        "epoch", sort=True).agg(time_s=("time_s", "first"), rows=("rejected", "size"),
                                rejected=("rejected", "sum"), used=("used", "sum"),
                                nis=("used_nis", "sum"))
    n = int(config.monitor.window_epochs)
    window = epochs.rolling(n, min_periods=1)
    rows = window["rows"].sum().to_numpy(dtype=float)
    share = window["rejected"].sum().to_numpy(dtype=float) / rows
    p_row = row_false_rejection(config)
    if p_row is None:
        p_rejected = p_rejected_on = np.ones(len(epochs))
    else:
        q = 1.0 - (1.0 - p_row) ** window["rows"].max().to_numpy(dtype=float)
        rejected = epochs["rejected"] > 0
        k = rejected.rolling(n, min_periods=1).sum().to_numpy(dtype=float)
        seen = np.minimum(np.arange(1, len(epochs) + 1), n)
        p_rejected = binom_sf(np.rint(k), seen, q)
        off = np.isin(epochs["time_s"].to_numpy(dtype=float),
                      np.asarray([] if off_network is None else off_network, dtype=float))
        k_on = (rejected & ~off).rolling(n, min_periods=1).sum().to_numpy(dtype=float)
        p_rejected_on = binom_sf(np.rint(k_on), seen, q)
    p_nis = chi2_sf(window["nis"].sum().to_numpy(dtype=float),
                    window["used"].sum().to_numpy(dtype=float))
    cfg = config.monitor
    worst = np.minimum(p_rejected, p_nis)
    out = np.where((p_rejected_on < cfg.p_lost) & (share >= cfg.lost_rejected_share),
                   STATUSES[2], np.where(worst < cfg.p_degraded, STATUSES[1], STATUSES[0]))
    return pd.DataFrame({"time_s": epochs["time_s"].to_numpy(dtype=float),
                         "status": out.astype(object), "p_rejected": p_rejected,
                         "rejected_share": share, "p_nis": p_nis})


def pseudo_nis(innov: Array, S_packed: Array) -> tuple[float, int]:
    """NIS sum ``Σ_k ν_kᵀ S_k⁻¹ ν_k`` of a cycle's pseudo-observation steps and its
    degrees of freedom (steps × rows).

    Parameters
    ----------
    innov : ndarray, shape (N, n_c)
    S_packed : ndarray, shape (N, n_c(n_c+1)/2)
        Their covariances, packed (`ekf.packing`).
    """
    from ekf.packing import unpack_sym
    nu = np.asarray(innov, dtype=float)
    if nu.size == 0:
        return 0.0, 0
    white = np.linalg.solve(unpack_sym(S_packed), nu[..., None])[..., 0]
    return float(np.einsum("nc,nc->", nu, white)), int(nu.size)


def pseudo_records(cycles: list, config) -> pd.DataFrame:
    """The pseudo-observation NIS test at each cycle (module docstring): ``time_s, status,
    p_pseudo_nis`` (empty without a continuous measurement).

    Parameters
    ----------
    cycles : list of (float, float, int)
        ``(time_s, NIS sum, degrees of freedom)`` of each cycle, in time order.
    config : railnav.config.NavigatorConfig
    """
    if not cycles:
        return pd.DataFrame(columns=["time_s", "status", "p_pseudo_nis"])
    table = pd.DataFrame(cycles, columns=["time_s", "nis", "dof"])
    window = table.rolling(int(config.monitor.window_epochs), min_periods=1)
    p = chi2_sf(window["nis"].sum().to_numpy(dtype=float),
                window["dof"].sum().to_numpy(dtype=float))
    status = np.where(p < config.monitor.p_degraded, STATUSES[1], STATUSES[0])
    return pd.DataFrame({"time_s": table["time_s"].to_numpy(dtype=float),
                         "status": status.astype(object), "p_pseudo_nis": p})


def combined_status_records(spawn: pd.DataFrame | None, *tests: pd.DataFrame
                            ) -> pd.DataFrame | None:
    """The run's status records: `spawn` (`railnav.navigation.spawning.Spawner.frame`)
    and the other `tests` (`row_records`, `pseudo_records`) merged on time, each time's
    status the worst of their latest (module docstring); the columns of all (NaN where
    one has no record at that time, ``action`` empty). None without `spawn` (a run
    without the spawn test has no status column)."""
    if spawn is None:
        return None
    tests = [t for t in tests if len(t)]
    if not tests:
        return spawn
    merged = spawn.rename(columns={"status": "status_0"})
    for k, test in enumerate(tests, start=1):
        merged = pd.merge(merged, test.rename(columns={"status": f"status_{k}"}),
                          on="time_s", how="outer", sort=True)
    rank = {s: k for k, s in enumerate(STATUSES)}
    worst = np.zeros(len(merged), dtype=int)
    names = [f"status_{k}" for k in range(len(tests) + 1)]
    for column in names:
        latest = merged[column].ffill().map(rank).fillna(0).to_numpy(dtype=int)
        worst = np.maximum(worst, latest)
    merged["status"] = np.array(STATUSES, dtype=object)[worst]
    merged["action"] = merged["action"].fillna("")
    return merged.drop(columns=names)
