"""Parallel-track identification (railnav/navigation/bank.py, track_bank_result.py,
track_runs.py) on the shipped double line (data/tracks/double_a.csv, double_b.csv: 4.5 m
apart).

References: the geometry of the two tracks (distance and tangent of the converted point);
the projection-based conversion for the Newton one; the forward probabilities against an
enumeration over all track sequences with transition matrices from `scipy.linalg.expm` of
the chain's generator; a static bank against the softmax of the engines' own update
log-likelihoods; the closed-form relaxation ``μ − ½ ∝ e^{−2εt}`` in an outage; the
issue's acceptance figure on a simulated trip.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.special import logsumexp

from railnav.errors import ConfigError
from railnav.filters.protocol import make_filter
from railnav.jobs.tracks import correct_share, run_simulated_tracks, track_names
from railnav.navigation.bank import Correspondence, TrackBankConfig, convert_state
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import C_n_e
from trackmodel.io import read_track

SPACING_M = 4.5
NAMES = ("double_a", "double_b")
#: Converted point: 4.5 m across within the shipped line's accuracy (1.2 cm), and abreast
#: (along-track residual of the projection, sub-millimetre).
ATOL_ACROSS_M = 0.02
ATOL_ABREAST_M = 1e-3
#: Newton conversion against the projection: one step from a guess up to ~0.3 m off in a
#: 600-m curve leaves ~κδ²/2 ≈ 0.1 mm; 1 mm bound. Yaw: that bound times the curvature of
#: the sharpest curve (1/600 m).
ATOL_NEWTON_S_M = 1e-3
ATOL_NEWTON_YAW_RAD = ATOL_NEWTON_S_M / 600.0
#: Same Gaussian algebra in another order (Cholesky vs the engine's update): relative.
RTOL_LOGLIK = 1e-9
#: The issue's acceptance: P(correct) > 0.99 at >= 95 % of the epochs after 60 s.
LEVEL, SHARE, AFTER_S = 0.99, 0.95, 60.0


@pytest.fixture(scope="module")
def double_line():
    return read_track(TRACKS_DIR / "double_a.csv"), read_track(TRACKS_DIR / "double_b.csv")


@pytest.fixture(scope="module")
def filters(double_line):
    config = navigator_config_for(get_scenario("curvy"))
    return [make_filter(track, config, None) for track in double_line]


def _state(filt, s, yaw_offset=0.0):
    x = np.zeros(filt.layout.size)
    point = filt.track.at(s)
    x[filt.layout.index("s")] = s
    x[filt.layout.index("yaw")] = float(point.azimuth) + yaw_offset
    x[filt.layout.index("pitch")] = float(point.elevation)
    x[filt.layout.index("v")] = 20.0
    return x


@pytest.mark.parametrize("s", [500.0, 4560.0, 9800.0, 12500.0, 20400.0])
def test_conversion_lands_abreast_on_the_other_track(filters, s):
    a, b = filters
    x = _state(a, s, yaw_offset=2e-3)
    P = np.eye(a.layout.size)
    xb, Pb = convert_state(a, b, x, P)
    pa, pb = a.track.at(s), b.track.at(xb[b.layout.index("s")])
    d = pb.r_e - pa.r_e
    t_e = C_n_e(float(pa.lat), float(pa.lon)) @ np.asarray(pa.u_n)
    assert abs(float(d @ t_e)) < ATOL_ABREAST_M
    assert np.linalg.norm(d) == pytest.approx(SPACING_M, abs=ATOL_ACROSS_M)
    # the heading keeps its 2 mrad offset from the track; speed and covariance unchanged
    assert xb[b.layout.index("yaw")] - float(pb.azimuth) == pytest.approx(2e-3, abs=1e-9)
    assert xb[b.layout.index("v")] == 20.0 and Pb is P


def test_newton_conversion_equals_the_projection(filters, rng):
    a, b = filters
    fast = Correspondence(filters)
    P = np.eye(a.layout.size)
    s = 3000.0
    for _ in range(40):   # a filter moving along, like the bank's cycles
        s += rng.uniform(5.0, 30.0)
        x = _state(a, s, yaw_offset=rng.normal(scale=1e-3))
        ref = convert_state(a, b, x, P)[0]
        got = fast(0, 1, x, P)[0]
        assert got[a.layout.index("s")] == pytest.approx(ref[a.layout.index("s")],
                                                        abs=ATOL_NEWTON_S_M)
        assert got[a.layout.index("yaw")] == pytest.approx(ref[a.layout.index("yaw")],
                                                          abs=ATOL_NEWTON_YAW_RAD)


@pytest.fixture(scope="module")
def short_run(double_line):
    """120 s on track B, σ_pr 3 m, a 40-s outage from 60 s, a fast crossing rate so
    that the outage's relaxation is visible."""
    sc = replace(get_scenario("curvy"), duration_s=120.0, sigma_pseudorange_m=3.0,
                 outages=((60.0, 40.0),))
    return run_simulated_tracks(list(double_line), NAMES, sc, true_track=1, seed=3,
                                bank=TrackBankConfig(crossing_rate_per_s=5e-3))


def test_probabilities_are_the_forward_recursion_of_the_chain(short_run):
    """Enumeration over all 2^K track sequences of the first K cycles, with the bank's
    recorded evidence and Π(Δt) = expm(Λ Δt) of the generator written here."""
    bank, K = short_run.bank, 12
    eps = bank.bank.crossing_rate_per_s
    gen = np.array([[-eps, eps], [eps, -eps]])
    dts = np.diff(np.concatenate([[0.0], bank.time_s[:K]]))
    log_pi = [None] + [np.log(expm(gen * dt)) for dt in dts[1:]]   # cycle 0 has no step
    weights = np.zeros(2)
    for seq in itertools.product(range(2), repeat=K):
        log_w = np.log(0.5) + sum(bank.log_likelihoods[k, m] for k, m in enumerate(seq))
        log_w += sum(log_pi[k][seq[k - 1], seq[k]] for k in range(1, K))
        weights[seq[-1]] += np.exp(log_w)
    np.testing.assert_allclose(bank.probabilities[K - 1], weights / weights.sum(), rtol=1e-9)


def test_outage_relaxes_towards_one_half_at_the_crossing_rate(short_run):
    """No evidence in the outage: μ_B − ½ = (μ_B(t₀) − ½) e^{−2ε(t − t₀)} exactly."""
    bank = short_run.bank
    eps = bank.bank.crossing_rate_per_s
    inside = np.flatnonzero((bank.time_s > 60.0) & (bank.time_s < 100.0))
    assert (bank.common_rows[inside] == 0).all()
    k0 = inside[0] - 1
    mu0 = bank.probabilities[k0, 1]
    expected = 0.5 + (mu0 - 0.5) * np.exp(-2 * eps * (bank.time_s[inside] - bank.time_s[k0]))
    np.testing.assert_allclose(bank.probabilities[inside, 1], expected, rtol=1e-12)
    assert bank.probabilities[inside[-1], 1] < mu0 - 0.1   # visibly less sure


def test_combined_result_follows_the_most_probable_track(short_run):
    out = short_run.outcome
    est = out.result.estimates
    prob = short_run.bank.probabilities_at(est["time_s"].to_numpy())
    best = np.array(NAMES)[np.argmax(prob, axis=1)]
    assert (est["track"].to_numpy() == best).all()
    np.testing.assert_allclose(est["track_probability"], prob.max(axis=1))
    assert set(out.summary["track_probabilities"]) == set(NAMES)
    assert out.summary["true_track"] == "double_b"
    assert sum(out.summary["track_probabilities"].values()) == pytest.approx(1.0)
    assert "track" in out.result.innovations.columns


def test_static_bank_is_the_softmax_of_the_engines_log_likelihoods(double_line):
    """ε = 0, every row used (no fault screen): the bank's evidence (from each screen's
    innovations and covariance) is the engines' own update log-likelihood, and the final
    probabilities are the softmax of their sums."""
    sc = replace(get_scenario("curvy"), duration_s=40.0, sigma_pseudorange_m=3.0)
    config = replace(navigator_config_for(sc), fault_detection=None, gate_probability=None)
    run = run_simulated_tracks(list(double_line), NAMES, sc, true_track=0, seed=4,
                               config=config, bank=TrackBankConfig(crossing_rate_per_s=0.0))
    totals = []
    for j, result in enumerate(run.bank.results):
        assert result.innovations["accepted"].all()
        ll = result.raw.log_lik_d
        np.testing.assert_allclose(run.bank.log_likelihoods[run.bank.common_rows > 0, j], ll,
                                   rtol=RTOL_LOGLIK)
        totals.append(ll.sum())
    expected = np.exp(np.array(totals) - logsumexp(totals))
    np.testing.assert_allclose(list(run.bank.final_probabilities().values()), expected,
                               rtol=1e-9)


def test_no_gnss_from_the_start_leaves_the_tracks_undecided(double_line):
    """GNSS from 30 s only: exactly ½ each until then, then the evidence decides."""
    sc = replace(get_scenario("curvy"), duration_s=60.0, sigma_pseudorange_m=3.0,
                 outages=((0.0, 30.0),))
    run = run_simulated_tracks(list(double_line), NAMES, sc, true_track=1, seed=1)
    before = run.bank.time_s < 30.0
    assert before.sum() >= 29 and (run.bank.common_rows[before] == 0).all()
    np.testing.assert_allclose(run.bank.probabilities[before], 0.5, rtol=1e-12)
    assert run.bank.probabilities[-1, 1] > LEVEL


def test_double_line_is_identified(double_line):
    """The issue's acceptance on a 200-s trip on each track (σ_pr = 3 m, IMU + GNSS)."""
    sc = replace(get_scenario("curvy"), duration_s=200.0, sigma_pseudorange_m=3.0)
    for true_track in (0, 1):
        run = run_simulated_tracks(list(double_line), NAMES, sc, true_track=true_track,
                                   seed=2)
        assert correct_share(run.bank, NAMES[true_track], after_s=AFTER_S,
                             level=LEVEL) >= SHARE


def test_bad_bank_inputs_are_refused(double_line):
    with pytest.raises(ConfigError, match="crossing_rate"):
        TrackBankConfig(crossing_rate_per_s=-1.0)
    with pytest.raises(ConfigError, match="distinct"):
        track_names(["a/x.csv", "b/x.csv"])
    sc = replace(get_scenario("curvy"), duration_s=10.0)
    with pytest.raises(ConfigError, match="true track"):
        run_simulated_tracks(list(double_line), NAMES, sc, true_track=2)
