"""Runs over candidate tracks (railnav/jobs/tracks.py: the network navigator on the tracks
as netelements without connections) on the shipped double line (data/tracks/double_a.csv,
double_b.csv: 4.5 m apart).

References: the geometry of the two tracks (distance and tangent of the converted point);
the projection-based conversion (`convert_state`) for the navigator's Newton one
(`converted`); the crossing matrix against `scipy.linalg.expm` of the chain's generator; a
static run (ε = 0, no fault screen) against the softmax of the log-likelihood sums of
independent single-track filters (`railnav.navigate`) started alike; the closed-form
relaxation ``μ − ½ ∝ e^{−2εt}`` in an outage; the issue's acceptance figure on a simulated
trip.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.special import logsumexp

from railnav.errors import ConfigError
from railnav.filters.protocol import make_filter
from railnav.jobs.network import candidate_starts
from railnav.jobs.tracks import (
    correct_share,
    run_simulated_tracks,
    track_names,
    track_nav,
    track_network,
)
from railnav.navigation.bank import convert_state
from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.navigator import navigate
from railnav.navigation.network_weights import crossing_matrix
from railnav.navigation.state_conversion import converted
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
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
#: The same Gaussian log-likelihoods summed over ~40 epochs in two runs of the same filter
#: arithmetic (the navigator's cycles and `navigate`'s chunks): relative.
RTOL_PROBABILITY = 1e-6
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
    """The navigator's IMM conversion (`converted`: a Newton step from the last offset of
    the pair) against `convert_state`'s projection, along a moving filter."""
    a, b = filters
    P = np.eye(a.layout.size)
    s = 3000.0
    for _ in range(40):
        s += rng.uniform(5.0, 30.0)
        x = _state(a, s, yaw_offset=rng.normal(scale=1e-3))
        ref = convert_state(a, b, x, P)[0]
        got = converted(a, b, x, P)[0]
        assert got[a.layout.index("s")] == pytest.approx(ref[a.layout.index("s")],
                                                        abs=ATOL_NEWTON_S_M)
        assert got[a.layout.index("yaw")] == pytest.approx(ref[a.layout.index("yaw")],
                                                          abs=ATOL_NEWTON_YAW_RAD)


@pytest.mark.parametrize("neighbours", [
    [[1], [0]],                                   # a double line
    [[1, 2], [0, 2], [0, 1], []],                 # three abreast, one alone
    [[1], [0, 2], [1]],                           # a chain: 0 and 2 are 9 m apart
])
def test_crossing_matrix_is_the_exponential_of_the_chains_generator(neighbours):
    rate, dt = 3e-2, 1.7
    gen = np.zeros((len(neighbours), len(neighbours)))
    for i, nb in enumerate(neighbours):
        if nb:
            gen[i, nb] = rate / len(nb)
            gen[i, i] = -rate
    Pi = crossing_matrix(neighbours, rate, dt)
    np.testing.assert_allclose(Pi, expm(gen * dt), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(Pi.sum(axis=1), 1.0, rtol=1e-12)


@pytest.fixture(scope="module")
def short_run(double_line):
    """120 s on track B, σ_pr 3 m, a 40-s outage from 60 s, a fast crossing rate so
    that the outage's relaxation is visible."""
    sc = replace(get_scenario("curvy"), duration_s=120.0, sigma_pseudorange_m=3.0,
                 outages=((60.0, 40.0),))
    return run_simulated_tracks(list(double_line), NAMES, sc, true_track=1, seed=3,
                                nav=track_nav(2, crossing_rate_per_s=5e-3))


def test_outage_relaxes_towards_one_half_at_the_crossing_rate(short_run):
    """No evidence in the outage: μ_B − ½ = (μ_B(t₀) − ½) e^{−2ε(t − t₀)} exactly (the
    chain of two tracks abreast)."""
    probs = short_run.probabilities
    eps = short_run.outcome.summary["crossing_rate_per_s"]
    inside = np.flatnonzero((probs.time_s > 60.0) & (probs.time_s < 100.0))
    assert inside.size >= 35 and (probs.common_rows[inside] == 0).all()
    k0 = inside[0] - 1
    mu0 = probs.probabilities[k0, 1]
    expected = 0.5 + (mu0 - 0.5) * np.exp(-2 * eps * (probs.time_s[inside] - probs.time_s[k0]))
    np.testing.assert_allclose(probs.probabilities[inside, 1], expected, rtol=1e-12)
    assert probs.probabilities[inside[-1], 1] < mu0 - 0.1   # visibly less sure


def test_combined_result_follows_the_most_probable_track(short_run):
    out = short_run.outcome
    est = out.result.estimates
    probs = short_run.probabilities
    np.testing.assert_array_equal(est["time_s"], probs.time_s)
    best = np.array(NAMES)[np.argmax(probs.probabilities, axis=1)]
    assert (est["track"].to_numpy() == best).all()
    np.testing.assert_allclose(est["track_probability"], probs.probabilities.max(axis=1))
    assert set(out.summary["track_probabilities"]) == set(NAMES)
    assert out.summary["true_track"] == "double_b"
    assert sum(out.summary["track_probabilities"].values()) == pytest.approx(1.0)
    inn = out.result.innovations
    assert set(inn["track"]) <= set(NAMES) and inn["track"].notna().all()


def test_static_run_is_the_softmax_of_single_track_log_likelihoods(double_line):
    """ε = 0, nothing pruned, every row used (no fault screen): each track's hypothesis is
    a filter of its own, so the final probabilities are the softmax of the log-likelihood
    sums of `railnav.navigate` on each track from the same start."""
    sc = replace(get_scenario("curvy"), duration_s=40.0, sigma_pseudorange_m=3.0)
    # the network navigator runs no divergence monitor: the single-track references neither
    config = replace(navigator_config_for(sc), fault_detection=None, gate_probability=None,
                     monitor=MonitorConfig(enabled=False))
    nav = replace(track_nav(2, crossing_rate_per_s=0.0), prune_probability=0.0)
    run = run_simulated_tracks(list(double_line), NAMES, sc, true_track=0, seed=4,
                               config=config, nav=nav)
    trip = simulate_trip(sc, track=double_line[0], seed=4)
    start = candidate_starts(trip, config, make_filter(double_line[0], config, None))
    totals = []
    evidence = run.probabilities.common_rows > 0
    for j, (name, track) in enumerate(zip(NAMES, double_line)):
        single = navigate(track, trip.sensor_data(), config,
                          initial=lambda f, name=name: start(f, name, 1))
        assert single.innovations["accepted"].all()
        np.testing.assert_allclose(run.probabilities.log_likelihoods[evidence, j],
                                   single.raw.log_lik_d, rtol=RTOL_LOGLIK)
        totals.append(single.raw.log_lik_d.sum())
    expected = np.exp(np.array(totals) - logsumexp(totals))
    got = run.outcome.summary["track_probabilities"]
    np.testing.assert_allclose([got[n] for n in NAMES], expected, rtol=RTOL_PROBABILITY)


def test_no_gnss_from_the_start_leaves_the_tracks_undecided(double_line):
    """GNSS from 30 s only: exactly ½ each until then, then the evidence decides."""
    sc = replace(get_scenario("curvy"), duration_s=60.0, sigma_pseudorange_m=3.0,
                 outages=((0.0, 30.0),))
    probs = run_simulated_tracks(list(double_line), NAMES, sc, true_track=1,
                                 seed=1).probabilities
    before = probs.time_s < 30.0
    assert before.sum() >= 29 and (probs.common_rows[before] == 0).all()
    np.testing.assert_allclose(probs.probabilities[before], 0.5, rtol=1e-12)
    assert probs.probabilities[-1, 1] > LEVEL


def test_double_line_is_identified(double_line):
    """The issue's acceptance on a 200-s trip on each track (σ_pr = 3 m, IMU + GNSS)."""
    sc = replace(get_scenario("curvy"), duration_s=200.0, sigma_pseudorange_m=3.0)
    for true_track in (0, 1):
        run = run_simulated_tracks(list(double_line), NAMES, sc, true_track=true_track,
                                   seed=2)
        assert correct_share(run.probabilities, NAMES[true_track], after_s=AFTER_S,
                             level=LEVEL) >= SHARE
        # the crossing prior keeps the other track alive (its floor ~εΔt), ready for a
        # crossover: never pruned (`TRACK_PRUNE_PROBABILITY`)
        assert (run.probabilities.probabilities[:, 1 - true_track] > 0.0).all()
        assert (run.network_run.network_result.cycles["hypotheses"] == 2).all()


def test_bad_track_run_inputs_are_refused(double_line):
    with pytest.raises(ConfigError, match="crossing_rate"):
        track_nav(2, crossing_rate_per_s=-1.0)
    with pytest.raises(ConfigError, match="distinct"):
        track_names(["a/x.csv", "b/x.csv"])
    with pytest.raises(ConfigError, match="at least two"):
        track_network(double_line[:1], NAMES[:1])
    sc = replace(get_scenario("curvy"), duration_s=10.0)
    with pytest.raises(ConfigError, match="true track"):
        run_simulated_tracks(list(double_line), NAMES, sc, true_track=2)
