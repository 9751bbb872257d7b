"""The constrained (inertial) filter's pseudorange variances under errors correlated from
epoch to epoch (``NavigatorConfig.pseudorange_correlation_s`` / ``_m``;
`railnav.filters.constrained.ConstrainedFilter`).

Against the closed form of a first-order Gauss–Markov sequence's long average: each
pseudorange row's variance is the white row's times ``(1 + ρ)/(1 − ρ)``,
``ρ = exp(−Δt/τ)``, Δt the simulated GNSS interval and τ ``min(τ_s, d/|v|)`` at the prior's speed, written out
here from the configured values (not through `railnav.filters.gnss_only_noise`); the
range-rate rows (Doppler: white) keep theirs; a bank's epoch
(`railnav.filters.epochs_together.observations_together`) gives the same rows; with τ = 0
(simulated trips) every row is the white filter's, to the bit.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from railnav.filters.epochs_together import observations_together
from railnav.filters.protocol import make_filter
from railnav.navigation.navigator import trip_samples
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track

#: The correlation the filter is told: τ (s) and the distance d (m) of
#: ``pseudorange_correlation_s`` / ``_m``.
TAU_S, DISTANCE_M = 60.0, 20.0
EPOCH = 5


@pytest.fixture(scope="module")
def trip():
    scenario = replace(get_scenario("curvy"), duration_s=10.0)
    simulated = simulate_trip(scenario, track=read_track(TRACKS_DIR / "curvy.csv"), seed=1)
    white = navigator_config_for(scenario)
    gnss = trip_samples(simulated.sensor_data(), white).gnss
    track = read_track(TRACKS_DIR / "curvy.csv")
    filt = make_filter(track, white, gnss)
    x_true = filt.truth_states(simulated.truth, *simulated.clock_truth(simulated.truth.time_s))[0]
    k = int(np.argmin(np.abs(np.asarray(simulated.truth.time_s) - gnss.time_s[EPOCH])))
    return {"track": track, "white": white, "gnss": gnss, "x": x_true[k],
            "interval_s": 1.0 / scenario.gnss_rate_hz, "filt": filt}


def _rows(filt, x, P):
    """The epoch's rows as the update gets them: ``(is pseudorange, R)`` per row."""
    rows = filt.observations(EPOCH, x, P)
    kinds = np.concatenate([np.full(o.z.size, "pseudorange" in o.model.name) for o in rows])
    return kinds, np.asarray(rows.R, dtype=float)


def _prior(trip, speed_mps: float):
    filt = trip["filt"]
    x = np.array(trip["x"], dtype=float)
    x[filt.layout.index("v")] = speed_mps
    P = np.diag(np.full(x.size, 1e-6))
    P[filt.layout.index("s"), filt.layout.index("s")] = 0.25
    P[filt.layout.index("clock_bias"), filt.layout.index("clock_bias")] = 1e4
    P[filt.layout.index("v"), filt.layout.index("v")] = 100.0   # the range rates pass the screen
    return x, P


@pytest.mark.parametrize("speed_mps, distance_m", [(0.0, DISTANCE_M), (1.0, DISTANCE_M),
                                                   (-8.0, DISTANCE_M), (8.0, 0.0)])
def test_pseudorange_variances_are_the_gauss_markov_long_average(trip, speed_mps, distance_m):
    x, P = _prior(trip, speed_mps)
    told = replace(trip["white"], pseudorange_correlation_s=TAU_S,
                   pseudorange_correlation_m=distance_m)
    tau = TAU_S if distance_m == 0.0 or speed_mps == 0.0 else \
        min(TAU_S, distance_m / abs(speed_mps))
    rho = math.exp(-trip["interval_s"] / tau)
    factor = (1.0 + rho) / (1.0 - rho)
    kinds, r_white = _rows(make_filter(trip["track"], trip["white"], trip["gnss"]), x, P)
    filt = make_filter(trip["track"], told, trip["gnss"])
    kinds_told, r_told = _rows(filt, x, P)
    np.testing.assert_array_equal(kinds_told, kinds)
    assert kinds.sum() >= 4 and (~kinds).sum() >= 4
    np.testing.assert_allclose(r_told[kinds], r_white[kinds] * factor, rtol=1e-12)
    np.testing.assert_array_equal(r_told[~kinds], r_white[~kinds])
    standing = (1.0 + math.exp(-trip["interval_s"] / TAU_S)) / \
        (1.0 - math.exp(-trip["interval_s"] / TAU_S))
    assert filt.pseudorange_inflation == pytest.approx(standing, rel=1e-12)   # the monitor's
    together = observations_together(
        [make_filter(trip["track"], told, trip["gnss"])], EPOCH, [(x, P)])[0]
    np.testing.assert_array_equal(np.asarray(together.R, dtype=float), r_told)


def test_white_errors_leave_every_row_as_it_was(trip):
    """τ = 0 (the simulated trips' setting): the filter's rows are those of a filter that
    never heard of the correlation, whatever the distance d."""
    x, P = _prior(trip, 8.0)
    a = make_filter(trip["track"], trip["white"], trip["gnss"])
    b = make_filter(trip["track"], replace(trip["white"], pseudorange_correlation_m=DISTANCE_M),
                    trip["gnss"])
    assert a.pseudorange_inflation == b.pseudorange_inflation == 1.0
    np.testing.assert_array_equal(_rows(a, x, P)[1], _rows(b, x, P)[1])


def _shifted_row(filt, x, P, k_sigma: float) -> tuple[str, float]:
    """Make the epoch's first pseudorange row's innovation at the prior ``k_sigma`` times
    its own σ, ``√(H P Hᵀ + σ²)`` (σ² the row's white variance, written out here from its
    Jacobian and the row builder's variance): the row's key and that σ."""
    build = filt.rows.observations
    rows = build(EPOCH, x, filt._chunk_end)
    model = filt.rows.rows.pseudorange
    offset = 0
    for o in rows:
        if o.model is model:
            break
        offset += o.rows
    z_pred, H = o.model.evaluate(x, o.p)
    sigma = math.sqrt(float(H[0] @ P @ H[0] + o.R[0]))
    shift = k_sigma * sigma - (float(o.z.reshape(-1)[0]) - float(z_pred[0]))

    def shifted(index, x_prior, end):
        out = build(index, x_prior, end)
        return [replace(r, z=r.z + np.eye(1, r.rows).reshape(r.z.shape) * shift)
                if r.model is model else r for r in out]
    filt.rows.observations = shifted
    return f"{filt.rows.rows_sv[-1][offset]}/pseudorange", sigma


@pytest.mark.parametrize("k_sigma, status", [(5.0, "rejected"), (2.0, "used")])
def test_screen_tests_a_row_at_its_own_variance(trip, k_sigma, status):
    """Told τ = 60 s standing (variance factor ~120 at 1 Hz, √ ~11), a pseudorange 5σ off
    (σ of its own epoch: ``H P Hᵀ`` + the white variance) is rejected by the fault screen,
    whose row test is at 3.73σ (`railnav.filters.fault_detection`); one 2σ off is used.
    Tested against the inflated variance the 5σ row would be 0.45σ off and used."""
    x, P = _prior(trip, 0.0)
    i = trip["filt"].layout.index("clock_bias")
    P[i, i] = 1.0             # the clock known to 1 m: the row's σ is mostly its own
    filt = make_filter(trip["track"], replace(trip["white"], pseudorange_correlation_s=TAU_S),
                       trip["gnss"])
    key, _ = _shifted_row(filt, x, P, k_sigma)
    filt.observations(EPOCH, x, P)
    last = filt.screen.last
    assert last.status[list(last.keys).index(key)] == status
