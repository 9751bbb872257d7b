"""The one-sided bound on the curvature pseudo-observation near an onset (issue 14, part 4:
σ shrinking through a long outage; `railnav.filters.one_sided`).

References: (1) the truncated normal's variance by numerical integration of the truncated
density (`scipy.integrate.quad`), against the closed form; (2) the simulated truth of
``outage_20min`` seed 5 (`benchmarks/bench_consistency.py`: ``curvy``, tactical, 20-min
outage from 60 s), where the filter without the bound ends thousands of σ off; (3) the
same filter with the bound off, on a trip that keeps σ_s small (GNSS throughout), whose
estimates must be bit-identical.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import integrate

from railnav.filters.one_sided import floor_variance, onsets, truncated_variance
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.io import read_track

#: Seed 5 of bench_consistency's outage_20min: the run the bound was built for.
SEED = 5
#: Its outage: 60–1260 s of a 1300-s trip.
OUTAGE_END_S = 1260.0


def _quad_variance(beta: float) -> float:
    """Var of N(0, 1) restricted to (−∞, β], by quadrature of the density in ``y = β − x``
    (weight ``exp(β y − y²/2)``: the density up to a constant, well scaled in the tail)."""
    weight = lambda y: math.exp(beta * y - 0.5 * y * y)           # noqa: E731
    top = max(beta, 0.0) + 40.0                                  # the density's whole tail

    def moment(k: int) -> float:
        return integrate.quad(lambda y: y ** k * weight(y), 0.0, top, epsabs=0.0,
                              epsrel=1e-11, limit=200)[0]

    mass = moment(0)
    return moment(2) / mass - (moment(1) / mass) ** 2


@pytest.mark.parametrize("beta", [-25.0, -8.0, -3.0, -0.17, 0.0, 0.5, 2.0, 6.0])
def test_truncated_variance_matches_quadrature(beta):
    assert truncated_variance(beta) == pytest.approx(_quad_variance(beta), rel=1e-7)


def test_truncated_variance_far_tail_is_the_series():
    """Far in the lower tail (the series branch) the variance is 1/β² − 6/β⁴ + O(β⁻⁶),
    continuous with the closed form across the switch."""
    beta = np.array([-99.0, -101.0, -1e4])
    np.testing.assert_allclose(truncated_variance(beta), 1.0 / beta ** 2 - 6.0 / beta ** 4,
                               rtol=1e-6)


def test_floor_is_the_harder_truncation():
    """The seed-5 numbers of docs/consistency-ablations.md: N(9350, 37²) cut at 9343.6 m
    keeps σ ≈ 21 m (the truncation away from the mean; the other side keeps more)."""
    floor = floor_variance(mean_m=9350.0, sigma_m=37.0, onset_m=9343.6)
    assert math.sqrt(floor) == pytest.approx(37.0 * math.sqrt(_quad_variance(-6.4 / 37.0)),
                                             rel=1e-7)
    assert 20.5 < math.sqrt(floor) < 21.5
    assert floor < 37.0 ** 2 * _quad_variance(6.4 / 37.0)


def _curvy():
    return read_track(TRACKS_DIR / "curvy.csv")


def test_onsets_of_curvy_include_the_seed5_clothoid():
    """The clothoid at 9343.6 m after the −1 % straight (7143.6–9343.6 m) is an onset."""
    found = onsets(_curvy())
    assert np.min(np.abs(found - 9343.5987756)) < 1e-6
    assert np.min(np.abs(found - 7143.5987756)) < 1e-6


def _outage_run(one_sided: bool):
    scenario = get_scenario("curvy").with_overrides(imu_errors="tactical",
                                                    duration_s=1300.0,
                                                    outages=[(60.0, OUTAGE_END_S - 60.0)])
    config = replace(navigator_config_for(scenario), one_sided=one_sided)
    return run_simulated(_curvy(), scenario, config=config, seed=SEED)


def _end(out, before_s: float | None = None) -> tuple[float, float]:
    """The along-track error and σ_s at the last estimate (before `before_s`), m."""
    est = out.result.estimates
    k = -1 if before_s is None else \
        int(np.flatnonzero(est["time_s"].to_numpy() < before_s - 1e-6)[-1])
    return float(out.errors.along_track_m[k]), float(est["sigma_s_m"].to_numpy()[k])


def test_outage_20min_seed5_is_not_confidently_wrong():
    """At the end of the 20-min outage (the last estimate before GNSS is back, 1260 s) and
    at the end of the trip the along-track error is inside 3σ_s."""
    out = _outage_run(True)
    for before_s in (OUTAGE_END_S, None):
        error, sigma = _end(out, before_s)
        assert abs(error) < 3.0 * sigma, (before_s, error, sigma)


def test_outage_20min_seed5_without_the_bound_is_confidently_wrong():
    """The reference for the test above: without the bound the rows collapse σ_s at the
    clothoid (9343.6 m) and the outage ends far outside 3σ_s (measured: −13.2 km, σ_s
    1.6 m). Once GNSS is back the divergence monitor says ``lost`` and its recovery (the
    default) restarts the filter from the epoch's fix (measured: at 1260 s), so the trip
    ends inside 3σ_s (−7.5 m, σ_s 15.5 m); without recovery it ended −14 km off."""
    out = _outage_run(False)
    error, sigma = _end(out, OUTAGE_END_S)
    assert abs(error) > 1000.0 and abs(error) > 3.0 * sigma, (error, sigma)
    actions = out.result.monitor
    assert (actions.loc[actions["time_s"] >= OUTAGE_END_S - 1e-6, "action"] == "reinit").any()
    error, sigma = _end(out)
    assert abs(error) < 3.0 * sigma, (error, sigma)


def test_without_onsets_in_reach_the_runs_are_bit_identical():
    """With GNSS throughout σ_s stays below 2 m, so the bound never acts: the estimates of
    the ``curvy`` trip (curves, clothoids, vertical curves) with the bound on and off are
    the same bits."""
    scenario = get_scenario("curvy").with_overrides(imu_errors="tactical", duration_s=200.0)
    config = navigator_config_for(scenario)
    runs = [run_simulated(_curvy(), scenario, config=replace(config, one_sided=flag), seed=2)
            .result.estimates for flag in (True, False)]
    assert runs[0].shape == runs[1].shape
    for name in runs[0].columns:
        a, b = runs[0][name].to_numpy(), runs[1][name].to_numpy()
        assert np.array_equal(a, b) or (a.dtype == object and list(a) == list(b)), name


def _near_onset_inputs(one_sided_filters: int, *, together: bool):
    """`ConstrainedFilter` inputs of 1 s of IMU samples from a prior at the clothoid start
    of ``curvy`` (9343.6 m) with σ_s 10 m, at 23 m/s: `inputs` of one fresh filter, or
    `inputs_together` of ``one_sided_filters`` fresh filters (bound on)."""
    from railnav.filters.constrained import ConstrainedFilter
    track = _curvy()
    config = navigator_config_for(get_scenario("curvy").with_overrides(imu_errors="tactical"))

    def make(flag: bool):
        filt = ConstrainedFilter(track, replace(config, one_sided=flag))
        filt.sample_interval_s = 0.01
        return filt

    probe = make(True)
    lay, point = probe.layout, track.at(9343.6)
    x = np.zeros(len(lay.names))
    x[lay.index("s")], x[lay.index("v")] = 9343.6, 23.0
    x[lay.index("yaw")], x[lay.index("pitch")] = float(point.azimuth), float(point.elevation)
    P = probe.initial_covariance(sigma_s_m=10.0, sigma_v_mps=0.2)
    t = 500.0 + 0.01 * np.arange(1, 101)
    u = np.tile([9.81 * math.sin(float(point.elevation)), 0.0, 9.81, 0.0, 0.0, 0.0],
                (t.size, 1))
    if together:
        return ConstrainedFilter.inputs_together([make(True) for _ in range(one_sided_filters)],
                                                 t, u, [(x, P)] * one_sided_filters, 500.0)
    return make(bool(one_sided_filters)).inputs(t, u, x, P, 500.0)


def test_the_hook_scales_r_c_alike_in_inputs_and_inputs_together():
    """Near the onset with σ_s 10 m the bound scales the rows' density (the geometry noise
    grows); a bank's `inputs_together` gives each filter the same arrays as its own
    `inputs`."""
    on, off = _near_onset_inputs(1, together=False), _near_onset_inputs(0, together=False)
    assert np.all(on[2] >= off[2]) and np.any(on[2] > 1.5 * off[2])
    assert np.array_equal(on[0], off[0]) and np.array_equal(on[1], off[1])
    for one in _near_onset_inputs(2, together=True):
        for a, b in zip(one, on):
            assert np.array_equal(a, b)
