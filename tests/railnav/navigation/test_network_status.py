"""The network run's row tests (`railnav.navigation.network_status`). References: the
binomial tail summed term by term with `math.comb`, SciPy's χ² distribution for the row
tests' false rejections and the NIS tail, statuses spelled out by hand for the merge, and the
network with heights ~100 m off its fixes (`tests.support.height_networks`), where every
fix row is rejected."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from railnav.config import NavigatorConfig
from railnav.jobs.network import run_files_network
from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.network_status import (
    combined_status_records,
    pseudo_nis,
    pseudo_records,
    row_false_rejection,
    row_records,
)
from tests.support.height_networks import write_fixes, write_geojson
from trackmodel.network import Network
from trackmodel.network_routes import load_network

CONFIG = NavigatorConfig()


def _p_row(config) -> float:
    return (1.0 - config.gate_probability) + \
        float(chi2.sf(config.fault_detection.nis_threshold, 1))


def _tail(k: int, n: int, q: float) -> float:
    """P(X >= k), X ~ Binomial(n, q), term by term."""
    return sum(math.comb(n, j) * q ** j * (1.0 - q) ** (n - j) for j in range(k, n + 1))


def _innovations(statuses: list[list[str]], nis=None) -> pd.DataFrame:
    """One epoch per list (time 0.5 s apart), one row per status; NIS 1 unless given
    (a list per epoch)."""
    return pd.DataFrame([{"time_s": 0.5 * e, "epoch": e, "status": s,
                          "nis": 1.0 if nis is None else nis[e][j]}
                         for e, rows in enumerate(statuses) for j, s in enumerate(rows)])


def test_false_rejection_is_the_two_row_tests_summed():
    assert row_false_rejection(CONFIG) == pytest.approx(_p_row(CONFIG), rel=1e-12)
    assert row_false_rejection(replace(CONFIG, fault_detection=None)) == \
        pytest.approx(1.0 - CONFIG.gate_probability, rel=1e-12)
    assert row_false_rejection(replace(CONFIG, fault_detection=None,
                                       gate_probability=None)) is None


def test_tails_are_the_binomial_law_of_rejected_epochs():
    """A window of 4 epochs: rejected rows in epochs 1 (two of three: counted once), 2 and
    4; ``excluded`` rows are not rejections; rows per epoch vary (the window's largest
    count sets q)."""
    config = replace(CONFIG, monitor=replace(MonitorConfig(), window_epochs=4))
    statuses = [["used"] * 3, ["rejected", "rejected", "used"], ["rejected", "used"],
                ["used", "excluded", "used", "used"], ["rejected", "used", "used"],
                ["used"] * 3]
    out = row_records(_innovations(statuses), config)
    p_row = _p_row(config)
    rows = [len(r) for r in statuses]
    bad = [int("rejected" in r) for r in statuses]
    for k in range(len(statuses)):
        lo = max(0, k - 3)
        q = 1.0 - (1.0 - p_row) ** max(rows[lo:k + 1])
        assert out["p_rejected"].iloc[k] == pytest.approx(
            _tail(sum(bad[lo:k + 1]), k + 1 - lo, q), rel=1e-9)
        share = sum(r.count("rejected") for r in statuses[lo:k + 1]) / sum(rows[lo:k + 1])
        assert out["rejected_share"].iloc[k] == pytest.approx(share, rel=1e-12)
    np.testing.assert_allclose(out["time_s"], 0.5 * np.arange(len(statuses)))
    expected = ["ok" if p >= config.monitor.p_degraded else
                "lost" if p < config.monitor.p_lost and s >= 0.5 else "degraded"
                for p, s in zip(out["p_rejected"], out["rejected_share"])]
    assert list(out["status"]) == expected
    # one rejected epoch in two is not an alarm (2q ≈ 1.7e-3), two in three are
    assert list(out["status"]) == ["ok", "ok", "degraded", "degraded", "degraded",
                                   "degraded"]


def test_nis_tail_is_chi2_of_the_used_rows_in_the_window():
    """Rows' NIS summed over the window's used rows (a rejected row's NIS left out)
    against χ² with one degree of freedom per used row, from SciPy's distribution; the
    window of 3 epochs; degraded below p_degraded, never lost."""
    config = replace(CONFIG, monitor=replace(MonitorConfig(), window_epochs=3))
    statuses = [["used"] * 2, ["used", "rejected"], ["used"] * 2, ["used"] * 2,
                ["excluded", "used"]]
    nis = [[0.5, 1.5], [2.0, 400.0], [9.0, 11.0], [12.0, 10.0], [50.0, 0.1]]
    out = row_records(_innovations(statuses, nis), config)
    used = [[v for v, st in zip(n, r) if st == "used"] for n, r in zip(nis, statuses)]
    for k in range(len(statuses)):
        window = [v for e in used[max(0, k - 2):k + 1] for v in e]
        assert out["p_nis"].iloc[k] == pytest.approx(chi2.sf(sum(window), len(window)),
                                                     rel=1e-9)
    flags = ["degraded" if p < config.monitor.p_degraded or r < config.monitor.p_degraded
             else "ok" for p, r in zip(out["p_nis"], out["p_rejected"])]
    assert list(out["status"]) == flags and "degraded" in flags and "lost" not in flags


def test_every_row_rejected_is_lost_from_the_second_epoch():
    """Every epoch's three rows rejected: tail q^k (k epochs, all rejected); q ≈ 3·p_row
    ≈ 8.7e-4 is below p_degraded alone, q² below p_lost, and the share is 1."""
    out = row_records(_innovations([["rejected"] * 3] * 12), CONFIG)
    q = 1.0 - (1.0 - _p_row(CONFIG)) ** 3
    n = CONFIG.monitor.window_epochs
    np.testing.assert_allclose(out["p_rejected"],
                               [q ** min(k, n) for k in range(1, 13)], rtol=1e-9)
    assert (out["p_nis"] == 1.0).all()                   # no row used: nothing to test
    assert list(out["status"]) == ["degraded"] + ["lost"] * 11


def test_the_worse_of_the_two_tests_holds_until_its_next_record():
    spawn = pd.DataFrame({"time_s": [1.0, 2.0, 3.0], "status": ["ok", "degraded", "ok"],
                          "p_fix": [0.5, 1e-4, 0.4], "d2_min": [1.0, 9.0, 1.5],
                          "action": ["", "", "spawn"]})
    rows = pd.DataFrame({"time_s": [1.0, 2.5, 3.0], "status": ["lost", "ok", "degraded"],
                         "p_rejected": [1e-9, 0.3, 1e-4], "rejected_share": [1.0, 0.2, 0.3]})
    out = combined_status_records(spawn, rows)
    assert list(out["time_s"]) == [1.0, 2.0, 2.5, 3.0]
    # 2.0: the rows' last (lost at 1.0) still holds; 2.5: the fix test's degraded holds
    assert list(out["status"]) == ["lost", "lost", "degraded", "degraded"]
    assert list(out["action"]) == ["", "", "", "spawn"]
    assert np.isnan(out["p_fix"].iloc[2]) and np.isnan(out["p_rejected"].iloc[1])
    assert combined_status_records(spawn, rows.iloc[:0]) is spawn
    assert combined_status_records(None, rows) is None


@pytest.fixture(scope="module")
def heights_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("network_status")
    fixes = write_fixes(tmp / "fixes.csv")
    net = load_network(write_geojson(tmp / "net.geojson", heights=False))
    return {claimed: run_files_network(Network(net.elements, [], heights=claimed),
                                       fixes_path=fixes).network_result
            for claimed in (False, True)}


def test_a_navigator_that_rejects_every_fix_is_not_ok(heights_runs):
    """The tracks' h = 0 taken as heights, ~100 m below the fixes: every fix row is
    rejected. The spawn test alone said ``ok`` on 86 of 90 epochs (the fixes agree
    horizontally); with the rows' test the status is ``degraded`` at the first fix epoch
    and ``lost`` from the second, in the estimates and in the summary's counts."""
    res = heights_runs[True]
    assert set(res.innovations["status"]) == {"rejected"}
    status = res.estimates["status"].to_numpy()
    assert status[0] == "degraded" and set(status[1:]) == {"lost"}
    assert (res.status_records["p_rejected"].iloc[1:] < CONFIG.monitor.p_lost).all()


def test_rows_used_leave_the_spawn_tests_status(heights_runs):
    """Read without heights the fixes' horizontal rows are all used: the rows' test says
    ``ok`` throughout and the status is the spawn test's."""
    res = heights_runs[False]
    assert set(res.innovations["status"]) == {"used"}
    records = res.status_records
    assert (records["p_rejected"] == 1.0).all() and (records["p_nis"] > 0.5).all()
    # the spawn test's own rule: degraded while its window fills (no p_fix) or below
    # p_degraded; lost below the spawn p-value (never here)
    p_fix = records["p_fix"].to_numpy(dtype=float)
    assert (np.nan_to_num(p_fix, nan=1.0) >= 1e-6).all()
    expected = np.where(np.isfinite(p_fix) & (p_fix >= CONFIG.monitor.p_degraded), "ok",
                        "degraded")
    assert list(records["status"]) == list(expected)
    assert (res.estimates["status"] == "ok").sum() == (expected == "ok").sum()


def test_fixes_off_every_track_are_not_lost(tmp_path):
    """Issue 14 (log_28554 in the airport tunnel, log_29083's jumps): carrier-fixed fixes
    drifting 30 m north of the only netelement (no position on the network explains them,
    `Network.project`) for 20 s: every row rejected, the navigator dead-reckons. Its σ_s
    holds: the error against the fixes' true place on the element (`write_fixes`:
    ``x = 100 m + 10 m/s · t``) is within 3σ_s at every estimate. Such fixes were ``lost``
    (the rows' test and the spawn test); they are rejected whatever the hypotheses:
    ``degraded`` from the stretch's second epoch, never ``lost``."""
    path = write_fixes(tmp_path / "fixes.csv")
    table = pd.read_csv(path)
    t = table["gps_time_s"] - table["gps_time_s"].iloc[0]
    off = (t >= 30.0) & (t < 50.0)
    table.loc[off, "lat_deg"] += 30.0 / 111_200.0
    table.to_csv(path, index=False, float_format="%.12f")
    net = load_network(write_geojson(tmp_path / "net.geojson", heights=False))
    near = net.project(table["lat_deg"].to_numpy()[off], table["lon_deg"].to_numpy()[off],
                       radius_m=25.0)
    assert len(near) == 0                                       # off every track
    res = run_files_network(Network(net.elements, [], heights=False),
                            fixes_path=path).network_result
    rows = res.innovations
    t0 = float(res.estimates["time_s"].iloc[0])
    in_off = (rows["time_s"] - t0 >= 30.0 - 1e-6) & (rows["time_s"] - t0 < 50.0 - 1e-6)
    assert in_off.sum() >= 40 and (rows.loc[in_off, "status"] == "rejected").all()
    est = res.estimates
    te = est["time_s"].to_numpy() - t0
    err = est["netelement_offset_m"].to_numpy() - (100.0 + 10.0 * te)
    stretch = (te >= 30.0) & (te < 50.0)
    assert np.all(np.abs(err[stretch]) <= 3.0 * est["sigma_s_m"].to_numpy()[stretch])
    status = est["status"].to_numpy()
    assert "lost" not in set(status)
    assert (status[(te >= 31.0) & (te < 50.0)] == "degraded").all()


def test_pseudo_nis_and_its_window():
    """The cycle's NIS with each step's 2×2 covariance inverted by hand (adjugate over the
    determinant); the window's tail against SciPy's χ² of the summed NIS and steps × 2
    degrees of freedom; degraded below p_degraded, never lost."""
    rng = np.random.default_rng(4)
    nu = rng.normal(size=(5, 2))
    a, b, c = 2.0 + rng.random(5), 0.3 * rng.random(5), 1.0 + rng.random(5)
    S_packed = np.column_stack([a, b, c])              # lower triangle row by row
    by_hand = sum((c[k] * nu[k, 0] ** 2 - 2 * b[k] * nu[k, 0] * nu[k, 1] + a[k] * nu[k, 1] ** 2)
                  / (a[k] * c[k] - b[k] ** 2) for k in range(5))
    nis, dof = pseudo_nis(nu, S_packed)
    assert nis == pytest.approx(by_hand, rel=1e-12) and dof == 10
    assert pseudo_nis(np.zeros((0, 2)), np.zeros((0, 3))) == (0.0, 0)
    config = replace(CONFIG, monitor=replace(MonitorConfig(), window_epochs=2))
    cycles = [(1.0, 10.0, 10), (2.0, 12.0, 10), (3.0, 60.0, 10), (4.0, 9.0, 10)]
    out = pseudo_records(cycles, config)
    sums = [(10.0, 10), (22.0, 20), (72.0, 20), (69.0, 20)]
    np.testing.assert_allclose(out["p_pseudo_nis"], [chi2.sf(s, d) for s, d in sums],
                               rtol=1e-9)
    assert list(out["status"]) == ["ok", "ok", "degraded", "degraded"]
    assert len(pseudo_records([], config)) == 0


def test_three_tests_merge_to_the_worst_latest():
    spawn = pd.DataFrame({"time_s": [1.0, 3.0], "status": ["ok", "ok"], "p_fix": [0.5, 0.4],
                          "d2_min": [1.0, 1.5], "action": ["", ""]})
    rows = pd.DataFrame({"time_s": [1.0, 3.0], "status": ["ok", "ok"],
                         "p_rejected": [1.0, 1.0], "rejected_share": [0.0, 0.0],
                         "p_nis": [0.5, 0.5]})
    pseudo = pd.DataFrame({"time_s": [0.5, 2.0, 3.0], "status": ["ok", "degraded", "ok"],
                           "p_pseudo_nis": [0.5, 1e-5, 0.2]})
    out = combined_status_records(spawn, rows, pseudo)
    assert list(out["time_s"]) == [0.5, 1.0, 2.0, 3.0]
    assert list(out["status"]) == ["ok", "ok", "degraded", "ok"]
