"""The divergence monitor (railnav/navigation/monitor.py) and the along-track protection
level (railnav/navigation/protection.py).

References: χ² and binomial tail probabilities (scipy.stats, a second implementation of the
special functions the monitor calls); the simulator's truth, which the filter never sees.
"""
from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from ekf.layout import StateLayout
from railnav.commands.run_report import report
from railnav.jobs.run import run_simulated
from railnav.navigation.monitor import FilterMonitor, status_at
from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.track_fixes import TrackFixes
from railnav.navigation.protection import along_track_protection
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from strapdown.imu_errors import imu_grade
from trackmodel.io import read_track

LAYOUT = StateLayout.from_blocks([("s", ["s"]), ("v", ["v"])])


def _chunk(t: float, nis_rows=(1.0,), accepted=None):
    """A one-epoch `ekf.FilterResult` stand-in: rows of unit S and the given NIS."""
    nis = np.asarray(nis_rows, dtype=float)
    acc = np.ones(nis.size, dtype=bool) if accepted is None else np.asarray(accepted)
    return SimpleNamespace(t_d=np.array([t]), innov_d=np.sqrt(nis), s_d=np.ones(nis.size),
                           accepted=acc, nis_c_sum=0.0, nis_c_count=0,
                           innov_c=np.zeros((0, 0)))


def _fixes(times, s_fix, sigma_m=1.0):
    n = len(times)
    return TrackFixes(np.asarray(times, dtype=float), np.asarray(s_fix, dtype=float),
                      np.full(n, sigma_m), np.full(n, np.nan), np.full(n, np.nan),
                      source=np.arange(n))


def _feed(monitor, times, s_prior, var_prior=0.0):
    x, P = np.zeros(2), np.diag([var_prior, 1.0])
    for t, s in zip(times, s_prior):
        x = np.array([s, 0.0])
        monitor.prior(t, x, P)
        out = monitor.epoch(_chunk(t), x, P)
        if out is not None:
            x, P = out
    return monitor.frame()


@pytest.mark.parametrize("margin, expected", [(-1e-6, "degraded"), (1e-6, "lost")])
def test_lost_threshold_is_the_chi2_quantile(margin, expected):
    """Ten epochs of equal |fix disagreement|, the nine other than the largest (the
    first) square-summing to the χ²₉ quantile of p_lost/2 (the fix test's tail is doubled,
    Bonferroni over its two statistics; ``lost`` needs the window to fail without its
    worst fix) ± a hair: the 10th epoch is lost just above it, only degraded just below
    (and not ok: p < 1e-3). The recorded p_fix is the whole window's."""
    cfg = MonitorConfig(recover=False)
    total = stats.chi2.isf(cfg.p_lost / 2, 9) * (1 + margin) * 10 / 9
    # alternating signs: the signed mean of the nine stays small; the first a hair larger
    d = np.sqrt(total / 10) * np.array([1, -1] * 5) * np.r_[1.0 + 1e-9, np.ones(9)]
    times = np.arange(10.0)
    monitor = FilterMonitor(LAYOUT, _fixes(times, d), cfg, gate_probability=None)
    frame = _feed(monitor, times, np.zeros(10))
    assert frame["status"].iloc[-1] == expected
    assert frame["p_fix"].iloc[-1] == pytest.approx(2 * stats.chi2.sf(total, 10), rel=1e-6)


def test_consistent_fixes_raise_few_alarms(rng):
    """2000 epochs of fixes that disagree by N(0, 1) σ: no ``lost`` (p_lost = 1e-6 per
    test), and ``degraded`` on at most ~1 % (5 tests at 1e-3, windows overlapping ×10-30,
    plus the first `min_epochs`)."""
    n = 2000
    times = np.arange(float(n))
    monitor = FilterMonitor(LAYOUT, _fixes(times, rng.standard_normal(n)), MonitorConfig(),
                            gate_probability=0.9999)
    frame = _feed(monitor, times, np.zeros(n))
    assert (frame["status"] == "lost").sum() == 0
    assert (frame["status"] == "degraded").mean() <= 0.01


def test_offset_filter_is_lost_and_restarted_at_the_fix():
    """A prior 30 m (30σ) off the fixes: the first epoch fails at 1e-6 (30² ≫ the χ²₁
    quantile, 23.9 with the doubled tail) but one fix cannot tell its own fault from the
    filter's: ``degraded``, the state kept. The second fix agrees with the first: ``lost``
    (the window without its worst fix still fails), and the state is re-initialised at
    the fix (σ floored at 1 m)."""
    times = np.arange(5.0)
    monitor = FilterMonitor(LAYOUT, _fixes(times, np.zeros(5)), MonitorConfig(recover=True),
                            gate_probability=None)
    x, P = np.array([30.0, 0.0]), np.diag([0.0, 1.0])
    monitor.prior(0.0, x, P)
    assert monitor.epoch(_chunk(0.0), x, P) is None
    assert monitor.records[0]["status"] == "degraded" and monitor.records[0]["action"] == ""
    assert monitor.records[0]["p_fix"] < MonitorConfig().p_lost
    monitor.prior(1.0, x, P)
    x_new, P_new = monitor.epoch(_chunk(1.0), x, P)
    assert monitor.records[1]["status"] == "lost" and monitor.records[1]["action"] == "reinit"
    assert x_new[0] == 0.0 and P_new[0, 0] == pytest.approx(1.0)


def test_rejected_rows_lost_only_when_most_are_rejected():
    """Gate 0.9999: 3 of 10 rows rejected per epoch is improbable (binomial tail ≪ 1e-6)
    but a minority: degraded; 6 of 10: lost."""
    for n_bad, expected in ((3, "degraded"), (6, "lost")):
        monitor = FilterMonitor(LAYOUT, None, MonitorConfig(recover=False), 0.9999)
        acc = np.arange(10) >= n_bad
        for t in range(5):
            monitor.prior(float(t), np.zeros(2), np.eye(2))
            monitor.epoch(_chunk(float(t), np.ones(10), acc), np.zeros(2), np.eye(2))
        rec = monitor.records[-1]
        assert rec["status"] == expected
        assert rec["p_rejected"] == pytest.approx(
            stats.binom.sf(5 * n_bad - 1, 50, 1e-4), rel=1e-6)


def test_status_at_takes_the_last_tested_epoch():
    records = pd.DataFrame({"time_s": [1.0, 2.0], "status": ["degraded", "lost"]})
    got = status_at(records, np.array([0.5, 1.0, 1.5, 2.0, 9.0]))
    assert list(got) == ["ok", "degraded", "degraded", "lost", "lost"]


def test_protection_level_closed_form():
    """PL = Φ⁻¹(1 − α/8)·σ·√f + (T + Φ⁻¹(1 − α/2))·σ_prior; NaN when lost."""
    pl = along_track_protection(np.array([1.0, 2.0, 1.0]), np.array([0.5, 0.0, 0.5]),
                                np.array([1.0, 4.0, 1.0]), np.array([False, False, True]),
                                integrity_risk=1e-5, threshold_sigma=3.0)
    k_ff, k_md = stats.norm.isf(1e-5 / 8), stats.norm.isf(1e-5 / 2)
    assert pl[0] == pytest.approx(k_ff + (3.0 + k_md) * 0.5, rel=1e-9)
    assert pl[1] == pytest.approx(k_ff * 2.0 * 2.0, rel=1e-9)
    assert np.isnan(pl[2])


# --- simulated runs -------------------------------------------------------------------

@pytest.fixture(scope="module")
def paper_track():
    return read_track(TRACKS_DIR / "paper2017.csv")


def _scenario(duration_s: float = 30.0):
    return get_scenario("paper2017").with_overrides(duration_s=duration_s)


def _joined(outcome):
    est = outcome.result.estimates
    err = outcome.errors.to_frame()[["time_s", "along_track_m"]]
    return est.merge(err, on="time_s")


@pytest.fixture(scope="module")
def clean_runs(paper_track):
    return [run_simulated(paper_track, _scenario(), seed=seed) for seed in (1, 2)]


def test_clean_runs_are_never_lost(clean_runs):
    for out in clean_runs:
        mon = out.result.statistics()["monitor"]
        assert mon["epochs"]["lost"] == 0 and mon["recoveries"] == 0
        assert set(out.result.estimates["status"]) <= {"ok", "degraded"}


def test_protection_levels_cover_the_truth(clean_runs):
    """Rows with the true s outside ±PL: none at 1e-5 and 1e-3 over 600 rows (at the
    declared 1e-3 per epoch, 5 or more violations would have probability < 4e-4)."""
    rows = [_joined(out) for out in clean_runs]
    err = np.concatenate([np.abs(r["along_track_m"].to_numpy()) for r in rows])
    for column in ("protection_level_m", "protection_level_risk_0p001_m"):
        pl = np.concatenate([r[column].to_numpy() for r in rows])
        assert np.isfinite(pl).all() and err.size >= 600
        assert (err > pl).sum() <= 4, column


def test_injected_imu_bias_is_flagged(paper_track):
    """IMU biases of 0.5 m/s² and 0.01 rad/s the filter is not told of (it assumes the
    paper2017 grade): the monitor says lost within 2 epochs, every row whose true error
    exceeds 3σ_s is flagged, no protection interval is given while lost, and the terminal
    report says the run ended lost."""
    sc = _scenario()
    config = navigator_config_for(sc)
    biased = replace(imu_grade(sc.imu_errors), accel_bias_mps2=0.5, gyro_bias_radps=0.01,
                     name="biased")
    out = run_simulated(paper_track, replace(sc, imu_errors=biased), config=config, seed=1)
    rows = _joined(out)
    beyond = np.abs(rows["along_track_m"]) > 3 * rows["sigma_s_m"]
    assert beyond.mean() > 0.5                                  # the filter really diverges
    assert (rows.loc[beyond, "status"] != "ok").all()
    mon = out.result.monitor
    assert (mon["status"] == "lost").to_numpy()[2:].all()
    lost = rows["status"] == "lost"
    assert np.isnan(rows.loc[lost, "protection_level_m"]).all()
    assert "LOST at the end of the run" in report(out, "out")


# --- 100 m/s round R = 100 m (issue 14: the false `lost` of the merged monitor) ---------

def _circle_scenario():
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.scenarios import Scenario
    from tests.railnav.filters.test_rate_step_joint import SPEED_MPS
    modelled = replace(imu_grade("tactical"), accel_scale_factor_ppm=0.0,
                       gyro_scale_factor_ppm=0.0, accel_misalignment_rad=0.0,
                       gyro_misalignment_rad=0.0, name="tactical-modelled")
    return Scenario(name="circle", profile=constant_speed(SPEED_MPS), duration_s=28.0,
                    imu_errors=modelled)


def test_high_speed_circle_raises_no_false_lost():
    """The consistent 100 m/s run round three full turns of R = 100 m
    (`test_rate_step_joint`, NEES inside its χ² band): the merged monitor said ``lost`` on
    160 of 280 epochs, its fix test comparing the filter with single-point fixes projected
    on the whole track, where each fix lands on any of the three passes (628 m apart).
    Now, over 4 seeds: no ``lost`` (a false ``lost`` has probability ≤ 2·p_lost per epoch,
    so any in N epochs ≤ 2·p_lost·N ≈ 2e-4), and the fix disagreements, independent from
    epoch to epoch (innovations) with variance ≤ 1 (the fix σ floor only widens them),
    square-sum below χ²_N's 1e-3 upper quantile."""
    from tests.railnav.filters.test_rate_step_joint import _circle_track
    cfg = MonitorConfig()
    statuses, d = [], []
    for seed in range(1, 5):
        offset_m = float(np.random.default_rng(seed).uniform(0.0, 1.0))
        mon = run_simulated(_circle_track(offset_m), _circle_scenario(),
                            seed=seed).result.monitor
        statuses.append(mon["status"].to_numpy())
        d.append(mon["fix_disagreement_sigma"].to_numpy())
    status, d = np.concatenate(statuses), np.concatenate(d)
    assert 2 * cfg.p_lost * status.size < 1e-3 and status.size >= 100
    assert (status == "lost").sum() == 0
    d = d[np.isfinite(d)]
    assert d.size >= 0.9 * status.size
    assert np.sum(d ** 2) <= stats.chi2.isf(1e-3, d.size)


@pytest.mark.parametrize("fault", ["offset", "imu_bias"])
def test_high_speed_circle_diverged_filter_is_flagged(fault):
    """The same circle with a filter that is really off: started 50 m ahead of the truth
    with σ_s 1 m, or with IMU biases (0.5 m/s², 0.01 rad/s) it is not told of. Every epoch
    whose true along-track error exceeds 3σ_s is flagged, and the run ends ``lost`` (the
    offset one from its second epoch; the bias shows first in the pseudo-observation NIS,
    ``degraded``, and is ``lost`` once its fix disagreement accumulates)."""
    from railnav.evaluation.metrics import error_series
    from railnav.jobs.run import truth_start
    from railnav.navigation.navigator import navigate
    from railnav.simulation.trip import simulate_trip
    from tests.railnav.filters.test_rate_step_joint import _circle_track
    sc = _circle_scenario()
    config = navigator_config_for(sc)
    config = replace(config, monitor=replace(config.monitor, recover=False))   # flags alone
    shift = 0.0
    if fault == "offset":
        config, shift = replace(config, initial_s_sigma_m=1.0), 50.0
    else:
        sc = replace(sc, imu_errors=replace(imu_grade(sc.imu_errors), accel_bias_mps2=0.5,
                                            gyro_bias_radps=0.01, name="biased"))
    trip = simulate_trip(sc, track=_circle_track(0.3), seed=1)

    def start(filt):
        x = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))[0][0].copy()
        x[filt.layout.index("s")] += shift
        return truth_start(filt, trip, config, x_true=x)
    result = navigate(trip.track, trip.sensor_data(), config, initial=start)
    err = error_series(result, truth=trip.truth, track=trip.track,
                       clock_truth=trip.clock_truth).to_frame()
    rows = result.estimates.merge(err[["time_s", "along_track_m"]], on="time_s")
    beyond = np.abs(rows["along_track_m"]) > 3 * rows["sigma_s_m"]
    assert beyond.sum() >= 10                                   # really off
    assert (rows.loc[beyond, "status"] != "ok").all()
    if fault == "offset":                    # 50σ off at once: lost from the second epoch
        assert beyond.iloc[0]                # (one fix cannot tell its fault from the filter's)
        assert list(result.monitor["status"].iloc[:2]) == ["degraded", "lost"]
    assert result.final_status == "lost"     # the bias: degraded first, then lost


def test_a_speed_far_off_is_lost_at_once_by_its_range_rates(paper_track, monkeypatch):
    """Issue 14 (the ring of stop 34: all six range rates rejected at 56σ, the monitor
    ``degraded`` only, its rejected-row test counting the window's rows of all kinds):
    a converged paper2017 filter (σ_v 0.09 m/s at 15 s) whose speed is set 50 m/s off
    after the 15-s update (through the loop's state-replacement path, as a restart;
    recovery off). At the next epoch every range rate fails the screen's row gate while
    the pseudoranges pass and the fix test does not fire (p_fix 1 at 16 s): the
    whole-kind test says ``lost`` there (c64c01c: ``degraded`` from 16 s to 21 s, the
    fix test's first ``lost`` later)."""
    sc = _scenario(20.0)
    config = navigator_config_for(sc)
    config = replace(config, monitor=replace(config.monitor, recover=False))
    epoch, seen = FilterMonitor.epoch, {}

    def injected(self, chunk, x, P):
        time_s = self._prior[0] if self._prior is not None else None
        out = epoch(self, chunk, x, P)
        if time_s == 15.0:
            x = x.copy()
            x[self.i_v] += 50.0
            seen["sigma_v"] = float(np.sqrt(P[self.i_v, self.i_v]))
            return x, P
        if time_s == 16.0:
            seen["screened"] = self.screen.epochs[-1]
        return out
    monkeypatch.setattr(FilterMonitor, "epoch", injected)
    out = run_simulated(paper_track, sc, config=config, seed=1)
    mon = out.result.monitor.set_index("time_s")
    assert seen["sigma_v"] < 0.2                              # 50 m/s: > 250σ off
    assert (mon.loc[:15.0, "status"] != "lost").all()
    assert mon.loc[16.0, "status"] == "lost"
    screened = seen["screened"]
    z2 = np.asarray(screened.innov) ** 2 / np.diagonal(screened.S)
    doppler = np.array([k.endswith("/range_rate") for k in screened.keys])
    assert doppler.sum() >= 4
    assert (z2[doppler] > stats.chi2.isf(1.9e-4, 1)).all()     # every range rate fails
    assert mon.loc[16.0, "p_fix"] > 1e-3                        # the fix test does not


# --- the monitor's windows against a plain recomputation on real runs -----------------

def _epoch_inputs(monkeypatch, paper_track, scenario, config):
    """Run `scenario` and record, at each monitored epoch, what the module docstring's
    statistics are built from: the prior, the snapshot fix (or the fix taken near the
    prior), the epoch's GNSS innovations, variances and gate decisions, and the
    pseudo-observation NIS; with the record the monitor wrote for it."""
    from railnav.navigation import track_fixes
    inputs, near = [], {}
    epoch, near_fix = FilterMonitor.epoch, track_fixes.TrackFixes.near

    def recording_near(self, j, s_guess):
        out = near_fix(self, j, s_guess)
        near[float(self.time_s[j])] = out
        return out

    def recording_epoch(self, chunk, x, P):
        prior, snapshot = self._prior, self._snapshot
        screened = self._screened               # the screen's epoch (None: no screen)
        fresh = screened is not None and all(screened is not e["screened"] for e in inputs[-1:])
        n_records = len(self.records)
        out = epoch(self, chunk, x, P)
        if len(self.records) > n_records:
            pseudo_dof = int(chunk.nis_c_count) * max(chunk.innov_c.shape[-1], 1) \
                if chunk.innov_c.ndim == 2 else 0
            inputs.append(dict(prior=prior, snapshot=snapshot, innov=chunk.innov_d.copy(),
                               S=chunk.s_d.copy(), accepted=np.asarray(chunk.accepted),
                               nis_c=float(chunk.nis_c_sum), nis_c_dof=pseudo_dof,
                               record=dict(self.records[-1]), config=self.config,
                               p_reject=self.p_reject, screened=screened,
                               kind=screened if fresh else None,
                               gate=self.screen.config.nis_threshold if fresh else None))
        return out

    monkeypatch.setattr(FilterMonitor, "epoch", recording_epoch)
    monkeypatch.setattr(track_fixes.TrackFixes, "near", recording_near)
    run_simulated(paper_track, scenario, config=config, seed=1)
    for e in inputs:
        e["near"] = near.get(e["prior"][0])
    return inputs


def _kind_tail(screened, gate):
    """The whole-kind test the plain way (module docstring of `kind_rejection`): for each
    of pseudorange / range rate with >= 4 rows all beyond the gate, the χ²_{m−1} tail of
    ``νᵀS⁻¹ν − (1ᵀS⁻¹ν)²/(1ᵀS⁻¹1)``; the smallest, 1 where none."""
    if screened is None:
        return 1.0
    tail = 1.0
    kinds = [key.split("/")[-1] for key in screened.keys]
    for kind in ("pseudorange", "range_rate"):
        rows = [i for i, k in enumerate(kinds) if k == kind]
        nu = np.asarray(screened.innov)[rows]
        S = np.asarray(screened.S)[np.ix_(rows, rows)]
        if len(rows) < 4 or any(n * n <= gate * S[i, i] for i, n in enumerate(nu)):
            continue
        Si = np.linalg.inv(S)
        one = np.ones(len(rows))
        residual = nu @ Si @ nu - (one @ Si @ nu) ** 2 / (one @ Si @ one)
        tail = min(tail, float(stats.chi2.sf(residual, len(rows) - 1)))
    return tail


def _reference_statuses(inputs, nav_config):
    """The module docstring's tests computed the plain way: per-epoch sums in Python,
    windows as lists, scipy.stats tails; the windows restart after a recovery. The
    rejected-row test counts epochs with a row rejected by the fault screen or the gate,
    each rejected with probability ``q = 1 − (1 − p_row)^m`` (``m`` the window's most rows
    in an epoch, ``p_row`` the screen's χ²₁ tail plus the gate's); ``lost`` from the fix
    test needs the window to fail without its largest ``d²``."""
    cfg = inputs[0]["config"]
    p_reject = (1.0 - nav_config.gate_probability) + float(
        stats.chi2.sf(nav_config.fault_detection.nis_threshold, 1))
    window, small, seen, out = [], [], 0, []
    shared = 0.0       # the prior's share of an error common to the fixes (small_disagreement)
    for e in inputs:
        time_s, _, var_prior = e["prior"]
        d = d_raw = np.nan
        var_fix = None
        if e["snapshot"] is not None:
            ds, var_fix, white = e["snapshot"]
            d = ds / np.sqrt(max(var_fix, cfg.min_fix_sigma_m ** 2) + var_prior)
            var_fix = var_fix if white else None
        elif e["near"] is not None:
            s_fix, sigma_fix = e["near"]
            ds = s_fix - e["prior"][1]
            var_fix = sigma_fix ** 2
            d = ds / np.sqrt(max(sigma_fix, cfg.min_fix_sigma_m) ** 2 + var_prior)
        if var_fix is not None:
            d_raw = ds / np.sqrt(var_fix) if shared > np.sqrt(var_prior) else np.nan
            gain = var_prior / (var_prior + var_fix)
            shared = (1.0 - gain) * shared + gain * np.sqrt(var_fix)
        acc = e["accepted"]
        nis = [nu * nu / s for nu, s, a in zip(e["innov"], e["S"], acc) if a]
        screened = e["kind"]                    # the screen's epoch when it ran, else None
        screen_rej = 0 if screened is None else int(sum(st == "rejected"
                                                        for st in screened.status))
        rows = max(len(acc), 0 if screened is None else len(screened.status))
        n_rej_e = int(len(acc) - len(nis)) + screen_rej
        window = (window + [dict(nis=sum(nis), n_acc=len(nis), n_rej=n_rej_e, rows=rows,
                                 d=d, nis_c=e["nis_c"], nis_c_dof=e["nis_c_dof"])])[
            -cfg.window_epochs:]
        small = (small + [d_raw])[-cfg.small_window_epochs:]
        seen += 1
        n_acc = sum(w["n_acc"] for w in window)
        n_rej = sum(w["n_rej"] for w in window)
        ds_ = [w["d"] for w in window if np.isfinite(w["d"])]
        raw = [v for v in small if np.isfinite(v)]

        def sf(value, dof):
            return float(stats.chi2.sf(value, dof)) if dof > 0 else 1.0

        def fix_tail(values):
            return min(1.0, 2.0 * min(sf(sum(v * v for v in values), len(values)),
                                      sf(sum(values) ** 2 / max(len(values), 1),
                                         min(len(values), 1))))
        worst = int(np.argmax([v * v for v in ds_])) if ds_ else 0
        p_fix_lost = fix_tail(ds_[:worst] + ds_[worst + 1:]) if len(ds_) >= 2 else 1.0
        epochs_with_rows = [w for w in window if w["rows"] > 0]
        k_rej = sum(w["n_rej"] > 0 for w in window)
        q = 1.0 - (1.0 - p_reject) ** max(w["rows"] for w in window)
        tails = {
            "p_gnss_nis": sf(sum(w["nis"] for w in window), n_acc),
            "p_rejected": 1.0 if k_rej == 0 else
            float(stats.binom.sf(k_rej - 1, len(epochs_with_rows), q)),
            "p_fix": fix_tail(ds_),
            "p_pseudo_nis": sf(sum(w["nis_c"] for w in window),
                               sum(w["nis_c_dof"] for w in window)),
            "p_fix_small": float(stats.chi2.cdf(sum(v * v for v in raw), len(raw)))
            if raw else 1.0,
            "p_kind_rejected": _kind_tail(e["kind"], e["gate"]),
            "fix_disagreement_sigma": abs(d) if np.isfinite(d) else np.nan,
            "variance_factor": sum(v * v for v in ds_) / len(ds_) if ds_ else np.nan}
        share = n_rej / (n_acc + n_rej) if n_acc + n_rej else 0.0
        if min(p_fix_lost, tails["p_kind_rejected"]) < cfg.p_lost or (
                tails["p_rejected"] < cfg.p_lost and share >= cfg.lost_rejected_share):
            status = "lost"
        elif min(tails[k] for k in ("p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis",
                                    "p_fix_small", "p_kind_rejected")
                 ) < cfg.p_degraded or seen < cfg.min_epochs:
            status = "degraded"
        else:
            status = "ok"
        out.append((time_s, status, tails))
        if status == "lost" and cfg.recover:
            window, small, seen, shared = [], [], 0, 0.0
    return out


@pytest.mark.parametrize("case", ["clean", "biased_recover"])
def test_monitor_windows_equal_a_plain_recomputation(monkeypatch, paper_track, case):
    """A 60-s paper2017 run (the 10- and 30-epoch windows fill; statuses ok and
    degraded), and one whose filter is not told of 0.5 m/s², 0.01 rad/s IMU biases, with
    recovery on (lost at every epoch, each a restart of the windows): every epoch's
    status equals the plain recomputation's, and every tail and window statistic agrees
    with it to 1e-9 (sums in another order; scipy.stats' tails)."""
    sc = _scenario(60.0)
    config = navigator_config_for(sc)
    if case == "biased_recover":
        sc = replace(sc, imu_errors=replace(imu_grade(sc.imu_errors), accel_bias_mps2=0.5,
                                            gyro_bias_radps=0.01, name="biased"))
        config = replace(config, monitor=replace(config.monitor, recover=True))
    inputs = _epoch_inputs(monkeypatch, paper_track, sc, config)
    reference = _reference_statuses(inputs, config)
    assert len(inputs) >= 55
    statuses = [e["record"]["status"] for e in inputs]
    assert statuses == [status for _, status, _ in reference]
    assert len(set(statuses)) >= (2 if case == "clean" else 1)
    for e, (time_s, _, tails) in zip(inputs, reference):
        rec = e["record"]
        assert rec["time_s"] == time_s
        for key, want in tails.items():
            got = rec[key]
            assert (np.isnan(got) and np.isnan(want)) or got == pytest.approx(
                want, rel=1e-9, abs=1e-300), (time_s, key)
