"""What an epoch's evidence counts when the errors are time-correlated
(`railnav.navigation.hypotheses.evidence_share`, `NetworkNavConfig.evidence_correlation_s`).

1. Against the exact likelihood of a first-order Gauss–Markov error sequence: two
   hypotheses a constant ``δ`` apart, declared variance σ² per epoch, errors correlated
   as ``σ² e^{−|t_i − t_j|/τ}``. The exact log-likelihood ratio's expectation is
   ``½ δ² 1ᵀ Σ⁻¹ 1`` (Σ inverted here by NumPy); the weights' is ``½ δ²/σ²`` per epoch
   times its share. The sum of the shares must be ``σ² 1ᵀ Σ⁻¹ 1`` (irregular intervals,
   a gap): more would over-count the correlated evidence (white counting, the share 1,
   over-counts it ~50-fold at τ = 60 s over 100 s). With a white part in the declared
   variance the shares count less than the exact information, never more.
2. In a pseudorange network run (not only for position fixes): declaring τ scales each
   epoch's log-likelihood of every netelement by that epoch's share, computed here in
   closed form, ``(1 − ρ)/(1 + ρ)``, ``ρ = e^{−Δt/τ}`` (the first epoch whole).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from railnav.navigation.hypotheses import evidence_share
from railnav.navigation.network_config import NetworkNavConfig

TAU_S = 60.0


def _gls_information(times_s: np.ndarray, tau_s: float) -> float:
    """``1ᵀ Σ⁻¹ 1`` of a unit-variance Gauss–Markov sequence sampled at `times_s`."""
    sigma = np.exp(-np.abs(times_s[:, None] - times_s[None, :]) / tau_s)
    ones = np.ones(times_s.size)
    return float(ones @ np.linalg.solve(sigma, ones))


def _shares(times_s: np.ndarray, nav: NetworkNavConfig) -> np.ndarray:
    """Each epoch's share as the navigator's cycles take it (the first after none)."""
    since = np.diff(np.concatenate([[-np.inf], times_s]))
    return np.array([evidence_share(nav, float(dt)) for dt in since])


@pytest.mark.parametrize("times_s", [np.arange(100.0),
                                     np.concatenate([np.arange(0.0, 30.0, 1.0),
                                                     np.arange(45.0, 60.0, 0.5),
                                                     [61.3, 64.0, 90.0, 200.0]])],
                         ids=["1 Hz", "irregular with gaps"])
def test_the_shares_count_the_exact_gauss_markov_information(times_s):
    """Σ shares = σ² 1ᵀ Σ⁻¹ 1 (module docstring, 1), to rounding; white counting would be
    the number of epochs."""
    nav = NetworkNavConfig(evidence_correlation_s=TAU_S)
    exact = _gls_information(times_s, TAU_S)
    assert float(np.sum(_shares(times_s, nav))) == pytest.approx(exact, rel=1e-9)
    assert times_s.size > 10.0 * exact          # what counting every epoch whole claims


@pytest.mark.parametrize("correlated", [0.1, 0.5, 0.9])
def test_a_white_part_in_the_declared_variance_is_never_over_counted(correlated):
    """Declared σ² = white (1 − q)σ² + Gauss–Markov qσ²: the shares sum to at most the
    exact information ``σ² 1ᵀ Σ⁻¹ 1`` (the rule takes the whole variance as correlated)."""
    times_s = np.arange(100.0)
    gm = np.exp(-np.abs(times_s[:, None] - times_s[None, :]) / TAU_S)
    sigma = (1.0 - correlated) * np.eye(times_s.size) + correlated * gm
    ones = np.ones(times_s.size)
    exact = float(ones @ np.linalg.solve(sigma, ones))
    shares = _shares(times_s, NetworkNavConfig(evidence_correlation_s=TAU_S))
    assert float(np.sum(shares)) <= exact


def test_white_errors_count_every_epoch_whole():
    """τ = 0: every epoch's evidence counts whole (share 1), the white likelihood."""
    times_s = np.arange(50.0)
    assert np.all(_shares(times_s, NetworkNavConfig()) == 1.0)


def test_a_pseudorange_run_counts_each_epoch_by_its_share():
    """Straight A0 and B 4.5 m apart, 20 s at 20 m/s (curvy's sensors, σ_pr 3 m, GPS),
    told A0 (B abreast): the same run with τ = 60 s declared gives every netelement each
    epoch's log-likelihood times ``(1 − ρ)/(1 + ρ)`` (module docstring, 2). No crossing
    prior, pruning, spawning or accelerometer evidence, so that the hypotheses' states do
    not depend on their weights and the two runs' filters see the same innovations."""
    from railnav.filters.protocol import make_filter
    from railnav.jobs.network import candidate_starts
    from railnav.navigation.network_navigator import navigate_network
    from railnav.navigation.network_start import NetworkStart
    from railnav.simulation.profiles import constant_speed
    from railnav.simulation.scenarios import get_scenario
    from railnav.simulation.switch_network import (
        SwitchNetworkSpec,
        route_track,
        switch_network,
    )
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    net = switch_network(SwitchNetworkSpec(loops=1, lead_in_m=1500.0))
    line = route_track(net, [("A0", 1)])
    scenario = replace(get_scenario("curvy"), profile=constant_speed(20.0), duration_s=20.0,
                       outages=(), start_s=50.0, sigma_pseudorange_m=3.0)
    config = navigator_config_for(scenario, filter="constrained", systems="G")
    trip = simulate_trip(scenario, track=line, seed=2, systems="G")
    white = NetworkNavConfig(spawn=False, crossing_rate_per_s=0.0, prune_probability=0.0,
                             continuous_evidence=False)
    runs = [navigate_network(net, trip.sensor_data(), config, nav=nav,
                             start=NetworkStart("A0", direction=1),
                             initial=candidate_starts(trip, config,
                                                      make_filter(line, config, None)),
                             near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])))
            for nav in (white, replace(white, evidence_correlation_s=TAU_S))]
    rho = math.exp(-1.0 / scenario.gnss_rate_hz / TAU_S)
    share = (1.0 - rho) / (1.0 + rho)
    epochs = [k for k, rows in enumerate(runs[0].cycles["evidence_rows"]) if rows > 0]
    assert len(epochs) >= 19
    for n, k in enumerate(epochs):
        white_ll, declared_ll = (r.element_log_likelihood[k] for r in runs)
        assert set(white_ll) == set(declared_ll) == {"A0", "B"}
        for element, value in white_ll.items():
            assert declared_ll[element] == pytest.approx((1.0 if n == 0 else share) * value,
                                                         rel=1e-9, abs=1e-12)
