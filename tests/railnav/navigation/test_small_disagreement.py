"""The monitor's lower-tail fix test (railnav/navigation/small_disagreement.py), on a
constant-velocity Kalman filter written out here and fed simulated fixes.

References: the simulated truth, which the filter never sees (its error against it, and
against its own σ_s, says whether an alarm is due); the prior's share of a common error in
closed form; χ² tails from scipy.stats.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from ekf.layout import StateLayout
from railnav.navigation.monitor import FilterMonitor
from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.small_disagreement import SmallDisagreement
from railnav.navigation.track_fixes import TrackFixes

LAYOUT = StateLayout.from_blocks([("s", ["s"]), ("v", ["v"])])
DT_S, SPEED_MPS = 1.0, 10.0


def _chunk(t: float):
    """A one-epoch `ekf.FilterResult` stand-in: one accepted row of NIS 1."""
    return SimpleNamespace(t_d=np.array([t]), innov_d=np.ones(1), s_d=np.ones(1),
                           accepted=np.ones(1, dtype=bool), nis_c_sum=0.0, nis_c_count=0,
                           innov_c=np.zeros((0, 0)))


def _run(fix_error_m, sigma_fix_m: float, accel_psd: float):
    """A constant-velocity filter (``s, v``; white acceleration of PSD `accel_psd`, m²/s³)
    on fixes ``s_true + fix_error_m`` at 1 Hz that it takes as white with σ `sigma_fix_m`,
    the monitor watching it (recovery off). Returns the filter's error against the truth,
    its σ_s after each update, each fix's disagreement with the prior ``δs`` and the
    prior's variance, and the monitor's frame."""
    n = fix_error_m.size
    times = np.arange(1, n + 1) * DT_S
    s_true = SPEED_MPS * times
    fixes = TrackFixes(times, s_true + fix_error_m, np.full(n, sigma_fix_m),
                       np.full(n, np.nan), np.full(n, np.nan), source=np.arange(n))
    monitor = FilterMonitor(LAYOUT, fixes, MonitorConfig(recover=False),
                            gate_probability=None)
    F = np.array([[1.0, DT_S], [0.0, 1.0]])
    Q = accel_psd * np.array([[DT_S ** 3 / 3, DT_S ** 2 / 2], [DT_S ** 2 / 2, DT_S]])
    x, P = np.array([0.0, SPEED_MPS]), np.diag([sigma_fix_m ** 2, 1.0])
    err, sigma, ds, var_prior = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for k, t in enumerate(times):
        x, P = F @ x, F @ P @ F.T + Q
        monitor.prior(t, x, P)
        ds[k], var_prior[k] = fixes.s_m[k] - x[0], P[0, 0]
        if np.isfinite(fixes.s_m[k]):          # (NaN: no fix at this epoch)
            gain = P[:, 0] / (P[0, 0] + sigma_fix_m ** 2)
            x = x + gain * (fixes.s_m[k] - x[0])
            P = P - np.outer(gain, P[0])
        monitor.epoch(_chunk(t), x, P)
        err[k], sigma[k] = x[0] - s_true[k], np.sqrt(P[0, 0])
    return err, sigma, ds, var_prior, monitor.frame()


def test_a_filter_that_follows_a_slow_fix_error_is_flagged(rng):
    """Fixes whose error is slow (Gauss-Markov, σ 3 m, τ 300 s) plus 0.3 m white, taken
    as white at σ 3 m: the filter (σ_s 1.4 m) follows the slow error and is beyond 3σ_s
    on far more than a consistent filter's 0.27 % of its epochs (against the truth). The
    lower-tail test must flag those: ``degraded`` on at least 95 % of them after the
    first minute, by ``p_fix_small``."""
    n, tau_s, sigma_b = 1500, 300.0, 3.0
    phi = np.exp(-DT_S / tau_s)
    b = np.empty(n)
    b[0] = sigma_b * rng.standard_normal()
    for k in range(1, n):
        b[k] = phi * b[k - 1] + sigma_b * np.sqrt(1 - phi ** 2) * rng.standard_normal()
    err, sigma, _, _, frame = _run(b + 0.3 * rng.standard_normal(n), 3.0, accel_psd=0.01)
    later = np.arange(n) >= 60
    beyond = later & (np.abs(err) > 3.0 * sigma)
    # the premise, from the truth: a consistent filter is beyond 3σ_s on 0.27 %
    assert beyond.sum() > 0.02 * later.sum()
    status = frame["status"].to_numpy()
    assert np.mean(status[beyond] == "degraded") >= 0.95
    assert np.mean(frame["p_fix_small"].to_numpy()[beyond] < 1e-3) >= 0.95


def test_white_fixes_at_their_sigma_raise_few_alarms(rng):
    """The same filter on white fixes at their stated σ (3 m): the filter is consistent
    (its error within 3σ_s on ≥ 99 % of epochs, against the truth) and the lower tail fails
    on at most 1 % of the epochs (its level 1e-3, windows of 30 overlapping)."""
    n = 3000
    err, sigma, _, _, frame = _run(3.0 * rng.standard_normal(n), 3.0, accel_psd=0.01)
    assert np.mean(np.abs(err) <= 3.0 * sigma) >= 0.99
    assert np.mean(frame["p_fix_small"].to_numpy() < 1e-3) <= 0.01


def test_fixes_that_reset_the_filter_do_not_fail_it_when_better_than_their_sigma(rng):
    """Fixes white at 1 cm, stated 3 cm, and a process noise that makes each prior wider
    than a fix (K ≈ 0.96: the filter is each fix, σ_s ≈ σ_fix), as the Brussels logs'
    carrier-fixed runs: the filter is conservative (its error within 3σ_s at every epoch,
    against the truth), and no correlation of the fixes could make it otherwise. Their
    disagreements are far below √(σ²_fix + σ²_prior) (the statistic before stop 36 fails at
    1e-3 on most epochs, computed here with scipy), but the lower-tail test never fails."""
    n, window = 600, MonitorConfig().small_window_epochs
    err, sigma, ds, var_prior, frame = _run(0.01 * rng.standard_normal(n), 0.03,
                                            accel_psd=0.1)
    assert np.all(np.abs(err) <= 3.0 * sigma)
    assert np.median(var_prior) > 0.03 ** 2
    old = np.cumsum(ds ** 2 / (0.03 ** 2 + var_prior))
    old = old[window - 1:] - np.r_[0.0, old[:-window]]
    assert np.mean(stats.chi2.cdf(old, window) < 1e-3) > 0.9
    assert (frame["p_fix_small"] >= 1e-3).all()
    assert (frame["status"].iloc[MonitorConfig().min_epochs:] == "ok").all()


@pytest.mark.parametrize("var_prior, var_fix", [(1.0, 9.0), (0.04, 0.0009)])
def test_prior_share_of_a_common_error_closed_form(var_prior, var_fix):
    """With a constant prior σ and fix σ, ``S`` after n fixes is ``σ_fix (1 − (1 − K)ⁿ)``,
    ``K = σ²_prior/(σ²_prior + σ²_fix)``; a term is tested (not NaN) once the previous
    ``S`` exceeds σ_prior, and is ``δs²/σ²_fix`` then; the tail is scipy's χ² cdf of the
    window's 30 terms (none where the prior is the more precise: 1)."""
    test = SmallDisagreement(30)
    gain = var_prior / (var_prior + var_fix)
    for n in range(1, 40):
        before = np.sqrt(var_fix) * (1 - (1 - gain) ** (n - 1))
        term = test.term(0.5, var_fix, var_prior)
        assert test.shared_m == pytest.approx(np.sqrt(var_fix) * (1 - (1 - gain) ** n),
                                              rel=1e-12)
        if before > np.sqrt(var_prior) * (1 + 1e-9):
            assert term == pytest.approx(0.25 / var_fix, rel=1e-12)
        elif before < np.sqrt(var_prior) * (1 - 1e-9):
            assert np.isnan(term)
        test.push(term)
    terms = [0.25 / var_fix] * 30 if var_fix > var_prior else []
    want = float(stats.chi2.cdf(sum(terms), len(terms))) if terms else 1.0
    assert test.tail() == pytest.approx(want, rel=1e-9)


def test_windows_with_missing_fixes_equal_a_plain_recomputation(rng):
    """Fixes missing at random epochs (a third; NaN: no fix there, the filter only
    predicts): each epoch's fix tails equal scipy's over the windows' epochs that had a fix,
    computed here with lists — ``p_fix`` over the last 10 ``d``, ``variance_factor``,
    ``fix_disagreement_sigma`` (NaN without a fix), and ``p_fix_small`` over the last 30
    finite terms, tested where the common-error share ``S`` (its recursion written out)
    exceeds σ_prior; the windows slide past their missing epochs."""
    n, sigma_fix, cfg = 150, 2.0, MonitorConfig(recover=False)
    missing = rng.random(n) < 1 / 3
    error = np.where(missing, np.nan, sigma_fix * rng.standard_normal(n))
    _, _, ds, var_prior, frame = _run(error, sigma_fix, accel_psd=0.01)
    d_all = ds / np.sqrt(max(sigma_fix, cfg.min_fix_sigma_m) ** 2 + var_prior)
    shared, terms = 0.0, []
    for k in range(n):
        d = [v for v in d_all[max(0, k - cfg.window_epochs + 1):k + 1] if np.isfinite(v)]
        if not missing[k]:
            terms.append(ds[k] ** 2 / sigma_fix ** 2 if shared > np.sqrt(var_prior[k])
                         else np.nan)
            gain = var_prior[k] / (var_prior[k] + sigma_fix ** 2)
            shared = (1 - gain) * shared + gain * sigma_fix
        else:
            terms.append(np.nan)
        raw = [v for v in terms[-cfg.small_window_epochs:] if np.isfinite(v)]
        row = frame.iloc[k]
        p_fix = min(1.0, 2 * min(stats.chi2.sf(sum(v * v for v in d), len(d)),
                                 stats.chi2.sf(sum(d) ** 2 / len(d), 1))) if d else 1.0
        assert row["p_fix"] == pytest.approx(p_fix, rel=1e-9, abs=1e-300)
        small = stats.chi2.cdf(sum(raw), len(raw)) if raw else 1.0
        assert row["p_fix_small"] == pytest.approx(small, rel=1e-9, abs=1e-300)
        if d:
            assert row["variance_factor"] == pytest.approx(np.mean(np.square(d)), rel=1e-12)
        else:
            assert np.isnan(row["variance_factor"])
        if missing[k]:
            assert np.isnan(row["fix_disagreement_sigma"])
        else:
            assert row["fix_disagreement_sigma"] == pytest.approx(abs(d_all[k]), rel=1e-12)
    assert missing[:cfg.window_epochs].any() and np.isfinite(np.array(terms)).sum() > 30
