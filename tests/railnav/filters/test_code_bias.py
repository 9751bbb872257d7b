"""The slow code error shared by an epoch's position rows (`railnav.filters.code_bias`).

References: the plain track rows evaluated at the shifted distance (a second
implementation of the receiver), weighted least squares written out with NumPy, the
first-order Gauss–Markov process in closed form, the covariance algebra ``cᵀ P c``.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ekf.cd_filter import CdFilter
from ekf.series import InputSeries
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.simulate import GnssSimConfig, default_nav_path, simulate_gnss
from railnav.config import NavigatorConfig
from railnav.errors import ConfigError
from railnav.filters.code_bias import (
    CodeBiasConfig,
    apparent_variance,
    code_bias_fix_position,
    code_bias_rows,
    snapshot_variance_s,
    with_scale,
)
from railnav.filters.fix_rows import build_fix_rows
from railnav.filters.gnss_epochs import GnssEpochs
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.filters.gnss_only_model import CODE_BIAS_STATE, build_gnss_only_model
from railnav.filters.gnss_rows import (
    build_gnss_rows,
    pseudorange_parameters,
    range_rate_parameters,
    track_rows,
)
from railnav.simulation.scenarios import DEFAULT_START_GPS_TIME_S, TRACKS_DIR
from trackmodel.earth import C_n_e
from trackmodel.io import read_track

CURVY = read_track(TRACKS_DIR / "curvy.csv")
#: s in a clothoid of curvy.csv (entry at 4300 m, 120 m long), where every term of the
#: rows' third-order track expansion is nonzero.
S_CLOTHOID_M = 4350.0
#: Two evaluations of the same expression through different CasADi graphs, m (the rows
#: are ~2e7 m: a few ulp).
ATOL_ROW_M = 1e-6
#: RK4 over 0.1-s steps of ḃ = −b/τ, τ ≥ 30 s: local error (dt/τ)⁵/120 per step.
RTOL_RK4 = 1e-8
LAYOUT = build_gnss_only_model(("E",), code_bias_time_s=300.0).layout


def _gnss(systems: str = "G", s_m: float = S_CLOTHOID_M, seed: int = 1) -> GnssEpochs:
    """Two simulated epochs (1 s apart) of a receiver at ``s`` on curvy.csv moving at
    10 m/s, as a filter reads them."""
    point = CURVY.at(np.array([s_m, s_m + 10.0]))
    v_e = 10.0 * np.einsum("kij,kj->ki", C_n_e(point.lat, point.lon), point.u_n)
    nav = read_rinex_nav(default_nav_path())
    sim = simulate_gnss(DEFAULT_START_GPS_TIME_S + np.array([0.0, 1.0]), point.r_e, v_e, nav,
                        GnssSimConfig(systems=systems, sigma_pr_m=3.0, sigma_rr_mps=0.1),
                        rng=np.random.default_rng(seed))
    cfg = replace(NavigatorConfig(filter="gnss-only").measurement, systems=systems)
    return GnssEpochs.from_files(sim.obs, nav, cfg, start_gps_time_s=DEFAULT_START_GPS_TIME_S,
                                 end_s=1.0)


def _epoch(s_m: float):
    """One simulated GPS+Galileo epoch at ``s``, prepared at the track point, and the
    track part of its rows."""
    part = track_rows(CURVY.at(s_m), earth=CURVY.earth)
    return _gnss("GE", s_m, seed=0).prepare(0, part[1:4]), part


def test_config_checks_its_values():
    assert CodeBiasConfig().enabled and not CodeBiasConfig(sigma=0.0).enabled
    for bad in ({"sigma": -1.0}, {"sigma": math.nan}, {"time_s": 0.0}, {"time_s": math.inf}):
        with pytest.raises(ConfigError, match="code_bias"):
            CodeBiasConfig(**bad)


@pytest.mark.parametrize("b, scale_m", [(0.0, 2.0), (1.3, 2.0), (-0.7, 0.5)])
def test_rows_are_the_track_rows_at_the_shifted_distance(b, scale_m):
    """h(x) of the code-bias rows = the plain rows (`build_gnss_rows`, another graph of the
    same receiver) at ``s + σ_e b``; ``∂h/∂b = σ_e ∂h/∂s`` for the pseudoranges and 0 for
    the range rates (given σ_e = 0)."""
    prepared, part = _epoch(S_CLOTHOID_M)
    rows, plain = code_bias_rows(LAYOUT, ("isb_E",)), build_gnss_rows(LAYOUT, ("isb_E",))
    i_s, i_b = LAYOUT.index("s"), LAYOUT.index(CODE_BIAS_STATE)
    x = np.zeros(LAYOUT.size)
    x[i_s], x[LAYOUT.index("v")], x[i_b] = S_CLOTHOID_M + 3.0, 10.0, b
    x[LAYOUT.index("clock_bias")], x[LAYOUT.index("isb_E")] = 40.0, -5.0
    shifted = x.copy()
    shifted[i_s] += scale_m * b
    p_pr = pseudorange_parameters(part, prepared, ("E",))
    z, H = rows.pseudorange.evaluate(x, with_scale(p_pr, scale_m))
    z0, H0 = plain.pseudorange.evaluate(shifted, p_pr)
    np.testing.assert_allclose(z, z0, rtol=0, atol=ATOL_ROW_M)
    np.testing.assert_allclose(H[:, i_b], scale_m * H0[:, i_s], rtol=1e-12, atol=1e-12)
    p_rr = range_rate_parameters(part, prepared)
    z, H = rows.range_rate.evaluate(x, with_scale(p_rr, 0.0))
    z0, _ = plain.range_rate.evaluate(x, p_rr)
    np.testing.assert_allclose(z, z0, rtol=0, atol=ATOL_ROW_M)
    assert not np.any(H[:, i_b])


def test_fix_position_rows_at_the_shifted_distance():
    """The code-bias fix position row = `build_fix_rows`'s at ``s + σ_e b``."""
    layout = build_gnss_only_model((), clock=False, code_bias_time_s=300.0).layout
    i_s, i_b = layout.index("s"), layout.index(CODE_BIAS_STATE)
    part = track_rows(CURVY.at(S_CLOTHOID_M), earth=CURVY.earth)
    axes = np.eye(3)
    p = np.column_stack([np.tile(part, (3, 1)), axes])
    x = np.zeros(layout.size)
    x[i_s], x[i_b] = S_CLOTHOID_M - 2.0, 0.8
    shifted = x.copy()
    shifted[i_s] += 1.5 * 0.8
    z, H = code_bias_fix_position(layout).evaluate(x, np.column_stack([p, np.full(3, 1.5)]))
    z0, H0 = build_fix_rows(layout).position.evaluate(shifted, p)
    np.testing.assert_allclose(z, z0, rtol=0, atol=ATOL_ROW_M)
    np.testing.assert_allclose(H[:, i_b], 1.5 * H0[:, i_s], rtol=1e-12, atol=1e-12)


def test_snapshot_variance_is_the_weighted_least_squares_covariance(rng):
    """[(Aᵀ W A)⁻¹]_ss against NumPy's inverse of the normal matrix; a clock column of
    zeros is not an unknown; fewer rows than unknowns give NaN."""
    m = 7
    H = np.zeros((m, 5))
    H[:, 0] = rng.standard_normal(m)            # s
    H[:, 2] = 1.0                                # clock bias
    H[:, 4] = rng.standard_normal(m)            # a state held at the prior
    variances = rng.uniform(1.0, 9.0, m)
    A = H[:, [0, 2]]
    expected = np.linalg.inv(A.T @ np.diag(1.0 / variances) @ A)[0, 0]
    assert snapshot_variance_s(H, variances, 0, (2, 3)) == pytest.approx(expected, rel=1e-12)
    assert math.isnan(snapshot_variance_s(H[:1], variances[:1], 0, (2,)))


def test_gauss_markov_state_has_unit_variance_and_decays():
    """Closed form of ḃ = −b/τ + w, q = 2/τ over T: mean b₀ e^(−T/τ), variance
    e^(−2T/τ) P₀ + (1 − e^(−2T/τ)); the other states do not feel it."""
    tau, T, dt = 30.0, 60.0, 0.1
    model = build_gnss_only_model((), code_bias_time_s=tau)
    i_b = model.layout.index(CODE_BIAS_STATE)
    q_c = model.process_noise_density(along_accel_sigma_mps2=0.0,
                                      oscillator=_zero_oscillator())
    x0 = np.zeros(model.layout.size)
    x0[i_b] = 1.0
    P0 = np.eye(model.layout.size) * 1e-6
    filt = CdFilter(model.process)
    filt.reset(x0, P0)
    t = np.arange(0.0, T + dt / 2, dt)
    filt.propagate(InputSeries(t=t, u=np.zeros((t.size, 0)), q_c=q_c))
    decay = math.exp(-T / tau)
    assert filt.x[i_b] == pytest.approx(decay, rel=RTOL_RK4)
    # the noise over a step is taken at its midpoint (the engine's quadrature): the
    # variance term ∫ q e^(−2(T−t)/τ) dt errs by its second derivative, (2/τ)² q T dt²/24
    quadrature = (2.0 / tau) ** 2 * (2.0 / tau) * T * dt ** 2 / 24.0
    assert filt.P[i_b, i_b] == pytest.approx(decay ** 2 * 1e-6 + 1.0 - decay ** 2,
                                             abs=quadrature)
    assert filt.P[i_b, model.layout.index("s")] == 0.0


def _zero_oscillator():
    from gnss_obs.oscillator import Oscillator
    return Oscillator(q_bias_m2ps=0.0, q_drift_m2ps3=0.0)


def test_state_only_with_correlated_errors():
    """The simulator's white errors (τ = 0) or k = 0: no state; the urban defaults: the
    state, and the rows of the code-bias model."""
    track = CURVY
    on = GnssOnlyFilter(track, NavigatorConfig(filter="gnss-only"), _gnss())
    white = GnssOnlyFilter(track, NavigatorConfig(filter="gnss-only",
                                                  pseudorange_correlation_s=0.0), _gnss())
    off = GnssOnlyFilter(track, NavigatorConfig(filter="gnss-only",
                                                code_bias=CodeBiasConfig(sigma=0.0)), _gnss())
    assert on.code_bias and CODE_BIAS_STATE in on.layout.names
    assert not white.code_bias and not off.code_bias
    assert CODE_BIAS_STATE not in white.layout.names + off.layout.names
    x = np.zeros(on.layout.size)
    x[on.layout.index("s")], x[on.layout.index("v")] = S_CLOTHOID_M, 10.0
    names = {o.model.name for o in on.observations(0, x, np.eye(on.layout.size))}
    assert names == {"track_code_bias_pseudorange", "track_code_bias_range_rate"}


def test_pseudorange_scale_is_k_times_the_single_epoch_sigma():
    """σ_e of an epoch's rows (the column ratio ∂h/∂b / ∂h/∂s) is k σ_1, σ_1 from the plain
    rows' Jacobian and white variances solved by `snapshot_variance_s`'s least squares."""
    k = 1.7
    filt = GnssOnlyFilter(CURVY, NavigatorConfig(filter="gnss-only",
                                                 code_bias=CodeBiasConfig(sigma=k)), _gnss())
    L = filt.layout
    x = np.zeros(L.size)
    x[L.index("s")], x[L.index("v")] = S_CLOTHOID_M, 10.0
    pr = [o for o in filt.observations(0, x, np.eye(L.size))
          if o.model.name.endswith("_pseudorange")][0]
    _, H = pr.model.evaluate(x, pr.p)
    plain = filt.rows.observations(0, x)[0]
    _, H0 = plain.model.evaluate(x, plain.p)
    A = H0[:, [L.index("s"), L.index("clock_bias")]] / np.sqrt(plain.R)[:, None]
    sigma_1 = math.sqrt(np.linalg.inv(A.T @ A)[0, 0])
    ratio = H[:, L.index(CODE_BIAS_STATE)] / H[:, L.index("s")]
    np.testing.assert_allclose(ratio, k * sigma_1, rtol=1e-9)


def test_start_gets_the_slow_variance():
    """A start fix's along-track variance: σ² + (k σ)², σ the same start without the state."""
    from railnav.navigation.initialization import GnssFix
    track = read_track(TRACKS_DIR / "east_west.csv")
    point = track.at(500.0)
    fix = GnssFix(time_s=0.0, r_e=np.asarray(point.r_e, dtype=float),
                  v_e=np.zeros(3), clock_bias_m={"G": 0.0}, clock_drift_mps=0.0,
                  cov_enu_m2=np.diag([9.0, 4.0, 16.0]), cov_v_enu_m2ps2=np.eye(3) * 0.04)
    k = 1.4
    on = GnssOnlyFilter(track, NavigatorConfig(filter="gnss-only",
                                               code_bias=CodeBiasConfig(sigma=k)), _gnss())
    off = GnssOnlyFilter(track, NavigatorConfig(filter="gnss-only",
                                                code_bias=CodeBiasConfig(sigma=0.0)), _gnss())
    _, P_on = on.initial_from_fix(fix)
    _, P_off = off.initial_from_fix(fix)
    var = P_off[off.layout.index("s"), off.layout.index("s")]
    assert P_on[on.layout.index("s"), on.layout.index("s")] == pytest.approx(var * (1 + k * k))
    i_b = on.layout.index(CODE_BIAS_STATE)
    assert P_on[i_b, i_b] == 1.0 and np.count_nonzero(P_on[i_b]) == 1


def test_apparent_variance_is_that_of_s_plus_scale_times_b(rng):
    """``cᵀ P c``, c = e_s + σ_e e_b, σ_e the scale given to the rows; ``P_ss`` where no
    row carries the state (range rates only)."""
    prepared, part = _epoch(S_CLOTHOID_M)
    from ekf.update import Observation
    rows = code_bias_rows(LAYOUT, ("isb_E",))
    scale = 2.3
    p = with_scale(pseudorange_parameters(part, prepared, ("E",)), scale)
    obs = Observation(rows.pseudorange, prepared.pseudorange_m[:, None],
                      prepared.sigma_pr_m ** 2, p)
    A = rng.standard_normal((LAYOUT.size, LAYOUT.size))
    P = A @ A.T
    x = np.zeros(LAYOUT.size)
    x[LAYOUT.index("s")] = S_CLOTHOID_M
    i_s, i_b = LAYOUT.index("s"), LAYOUT.index(CODE_BIAS_STATE)
    expected = P[i_s, i_s] + 2 * scale * P[i_s, i_b] + scale ** 2 * P[i_b, i_b]
    assert apparent_variance([obs], x, P, i_s, i_b) == pytest.approx(expected, rel=1e-9)
    rr = Observation(rows.range_rate, prepared.range_rate_mps[:, None],
                     prepared.sigma_rr_mps ** 2,
                     with_scale(range_rate_parameters(part, prepared), 0.0))
    assert apparent_variance([rr], x, P, i_s, i_b) == P[i_s, i_s]


def test_code_fixes_carry_the_state_and_carrier_fixes_do_not():
    """The fix-based filter with ``correlated_code_errors``: the position rows of a code fix
    (``single``, ``dgps``) are `code_bias_fix_position`'s with σ_e = k σ_along, σ_along
    the fix's own (the white row's σ, `test_fix_filter`'s rows without the options);
    a carrier fix's rows stay the plain ones."""
    from railnav.filters.fix_epochs import EpochSchedule, FixEpochs, FixModelConfig
    from railnav.simulation.fixes import FixSimConfig, trip_fixes
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.scenarios import Scenario
    from railnav.simulation.trip import simulate_trip
    straight = read_track(TRACKS_DIR / "east_west.csv")
    sc = Scenario(name="fix_test", profile=constant_speed(15.0), duration_s=12.0,
                  imu_rate_hz=10.0)
    trip = simulate_trip(sc, track=straight, seed=2, gnss=False)
    mix = (("rtk_fixed", 0.25), ("rtk_float", 0.25), ("dgps", 0.25), ("single", 0.25))
    log = trip_fixes(trip, FixSimConfig(rate_hz=1.0, quality_mix=mix, segment_s=2.0))
    fixes = FixEpochs.from_table(log.table, start_gps_time_s=sc.start_gps_time_s)
    schedule = EpochSchedule.merge(np.zeros(0), fixes.time_s)
    k = 1.2
    on = GnssOnlyFilter(straight, NavigatorConfig(
        filter="gnss-only", code_bias=CodeBiasConfig(sigma=k),
        fix_model=FixModelConfig(correlated_code_errors=True)), fixes=fixes, schedule=schedule)
    white = GnssOnlyFilter(straight, NavigatorConfig(filter="gnss-only"), fixes=fixes,
                           schedule=schedule)
    assert on.layout.names == ("s", "v", CODE_BIAS_STATE)
    i_s, i_b = on.layout.index("s"), on.layout.index(CODE_BIAS_STATE)
    kinds = set()
    s_fix = straight.project(fixes.lat, fixes.lon).s        # a prior the screen accepts
    for j, quality in enumerate(fixes.quality):
        x = np.array([s_fix[j], 15.0, 0.0])
        rows = on.observations(j, x, np.eye(3))
        plain = white.observations(j, x[:2], np.eye(2))
        position = [o for o in rows if o.model.name == "fix_position"][0]
        plain_position = [o for o in plain if o.model.name == "fix_position"][0]
        _, H = position.model.evaluate(x, position.p)
        if str(quality) in ("single", "dgps"):
            kinds.add("code")
            sigma_along = math.sqrt(plain_position.R[0])
            # the cross and up rows' ∂h/∂s vanish at s_ref (rounding ~1e-17 left)
            np.testing.assert_allclose(H[:, i_b], k * sigma_along * H[:, i_s], rtol=1e-9,
                                       atol=1e-12)
        else:
            kinds.add("carrier")
            assert not np.any(H[:, i_b])
    assert kinds == {"code", "carrier"}
