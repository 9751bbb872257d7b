"""A scenario's code multipath (`Scenario.multipath_sigma_m`, ``multipath_tau_s``) reaches
the GNSS simulator: the trip's pseudoranges minus those of the same trip without it (the
white draws come first and are the same) are, per satellite, a first-order Gauss–Markov
sequence of steady σ ``σ_mp/sin(max(el, 5°))`` (`gnss_obs.simulate`). Its one-epoch
innovations ``m_{k+1} − ρ m_k`` (ρ = e^{−Δt/τ}) then have σ ``σ_mp √(1 − ρ²)`` once
multiplied by ``sin(el)`` (~1000 of them here: ±5 % at 2σ). Without multipath the
scenario's JSON is what it was (no multipath entries)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import get_scenario, scenario_to_dict
from railnav.simulation.trip import simulate_trip

SIGMA_MP_M, TAU_S = 2.0, 30.0


def test_multipath_is_a_gauss_markov_bias_per_satellite():
    base = replace(get_scenario("curvy"), profile=constant_speed(20.0), duration_s=120.0,
                   outages=())
    white = simulate_trip(base, seed=4, systems="G").gnss
    trip = simulate_trip(replace(base, multipath_sigma_m=SIGMA_MP_M, multipath_tau_s=TAU_S),
                         seed=4, systems="G").gnss
    both = trip.obs.table.merge(white.obs.table, on=["gps_time_s", "sv"], suffixes=("", "_w"))
    both = both.merge(trip.satellites[["gps_time_s", "sv", "elevation_deg"]],
                      on=["gps_time_s", "sv"])
    assert np.array_equal(both["doppler_hz"], both["doppler_hz_w"])     # pseudoranges only
    rho = math.exp(-1.0 / base.gnss_rate_hz / TAU_S)
    steps = []
    for _, sat in both.sort_values("gps_time_s").groupby("sv"):
        m = (sat["pseudorange_m"] - sat["pseudorange_m_w"]).to_numpy()
        sin_el = np.sin(np.maximum(np.radians(sat["elevation_deg"].to_numpy()),
                                   np.radians(5.0)))
        consecutive = np.isclose(np.diff(sat["gps_time_s"].to_numpy()), 1.0)
        steps.append(((m[1:] - rho * m[:-1]) * sin_el[1:])[consecutive])
    steps = np.concatenate(steps)
    assert steps.size > 800
    assert np.std(steps) == pytest.approx(SIGMA_MP_M * math.sqrt(1.0 - rho ** 2), rel=0.05)


def test_the_json_has_multipath_only_when_simulated():
    sc = get_scenario("curvy")
    assert "multipath_sigma_m" not in scenario_to_dict(sc)
    data = scenario_to_dict(replace(sc, multipath_sigma_m=1.0, multipath_tau_s=60.0))
    assert (data["multipath_sigma_m"], data["multipath_tau_s"]) == (1.0, 60.0)
    with pytest.raises(ConfigError, match="multipath_tau_s"):
        replace(sc, multipath_sigma_m=1.0, multipath_tau_s=0.0)
    with pytest.raises(ConfigError, match="multipath_sigma_m"):
        replace(sc, multipath_sigma_m=-1.0)
