"""The network navigator's one noise scale for all its hypotheses
(`railnav.filters.noise_scale.BankNoiseScale`, fed in
`railnav.navigation.network_navigator`): a line and its parallels 4.5 m apart as a
network without connections (`benchmarks/bench_speed.py`'s bank, shorter), the
pseudoranges simulated at 3 m and told 1 m, so that the scale rises.

Every hypothesis's epoch is watched (its filter's screened record, the rows' update
variances, the factors it recorded); the test feeds a single `NoiseScale` of its own with
the screened rows of the hypothesis it finds most probable before each epoch (the largest
log weight, the first of equals; through the spawn that the told σ brings) and checks: every hypothesis's rows of an epoch carry
the factors of that single scale, to the bit, and their pseudorange variances are the
told σ² times its k² (times the correlated-error inflation), the wrong tracks' as the
right one's; the wrong tracks' own rows would have raised a scale of their own above the
shared one, and their Gaussian likelihood at its variances (closed form, SciPy) above the
one at the shared variances: the penalty a scale of its own took off before. A bank of one gives the single
filter's factors (`tests/railnav/filters/test_bank_noise_scale.py`, and the
``innovations.csv`` column here against the watched factors).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from railnav.filters.common import ROW_KINDS
from railnav.filters.bank_noise_scale import MemberNoiseScale
from railnav.filters.noise_scale import NoiseScale
from railnav.filters.protocol import make_filter
from railnav.jobs.network import candidate_starts
from railnav.jobs.tracks import track_nav, track_network
from railnav.navigation.hypothesis_step import EngineStepper
from railnav.navigation.network_navigator import navigate_network
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track
from trackmodel.offset import offset_track

SPACING_M = 4.5
TRIP_S = 40.0
SIMULATED_PR_M, TOLD_PR_M = 3.0, 1.0
NAMES = ["left", "line", "right"]


@pytest.fixture(scope="module")
def watched():
    """The run, and per epoch: the hypotheses' elements, log weights and scales before
    it, and each one's screened rows ``(record, kind, R, inflation, factors)``."""
    base = read_track(TRACKS_DIR / "double_a.csv")
    tracks = [offset_track(base, -SPACING_M), base, offset_track(base, SPACING_M)]
    scenario = replace(get_scenario("curvy"), duration_s=TRIP_S,
                       sigma_pseudorange_m=SIMULATED_PR_M)
    trip = simulate_trip(scenario, track=base, seed=2)
    config = navigator_config_for(scenario)
    config = replace(config, measurement=replace(config.measurement, sigma_pr_m=TOLD_PR_M))
    initial = candidate_starts(trip, config, make_filter(base, config, None))
    near = (float(trip.truth.lat[0]), float(trip.truth.lon[0]))
    epochs: list[dict] = []
    step, seen = EngineStepper.step, MemberNoiseScale.seen

    def step_spy(self, hyps, a, b, epoch):
        if epoch is not None:
            epochs.append({"time_s": float(self.t[b]), "elements": [h.element for h in hyps],
                           "log_weights": [h.log_weight for h in hyps],
                           "scales": [h.filt.noise_scale for h in hyps], "seen": {}})
        return step(self, hyps, a, b, epoch)

    def seen_spy(self, record, kind, R, inflation):
        epochs[-1]["seen"][self] = (record, np.array(kind), np.array(R),
                                    None if inflation is None else np.array(inflation),
                                    self.history[-1])
        return seen(self, record, kind, R, inflation)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(EngineStepper, "step", step_spy)
        mp.setattr(MemberNoiseScale, "seen", seen_spy)
        result = navigate_network(track_network(tracks, NAMES), trip.sensor_data(), config,
                                  nav=track_nav(len(tracks)), initial=initial, near=near)
    return result, config, epochs


def _shared_factors(config, epochs):
    """The factors of each epoch from a single scale fed by the most probable
    hypothesis's rows (module docstring), and the index of that hypothesis."""
    single = NoiseScale(config.noise_scale)
    out = []
    for e in epochs:
        top = int(np.argmax(e["log_weights"]))
        single.begin_epoch()
        out.append((single.history[-1], top))
        record, kind, R, inflation, _ = e["seen"][e["scales"][top]]
        single.seen(record, kind, R, inflation)
    return out


def test_every_hypothesis_has_the_factors_of_the_most_probable_ones_rows(watched):
    result, config, epochs = watched
    assert len(epochs) > TRIP_S
    shared = _shared_factors(config, epochs)
    for e, (factors, _) in zip(epochs, shared):
        assert set(e["seen"]) == set(e["scales"])              # every one screened
        for scale in e["scales"]:
            assert e["seen"][scale][4] == factors
    assert max(f[0] for f, _ in shared) > 1.5                  # the scale rose
    # the told σ fails the spawn test of the epochs' own fixes too: a spawn, through
    # which the one scale goes on
    assert len(result.spawns) == 1 and shared[-1][0][0] > 1.5


def test_the_rows_variances_are_the_told_sigma_at_the_shared_factor(watched):
    """Pseudorange ``R = σ_told² k² inflation`` for every hypothesis, wrong tracks too."""
    _, config, epochs = watched
    for e, (factors, _) in zip(epochs, _shared_factors(config, epochs)):
        for scale in e["scales"]:
            _, kind, R, inflation, _ = e["seen"][scale]
            pr = kind == ROW_KINDS[0]
            infl = 1.0 if inflation is None else inflation[pr]
            np.testing.assert_allclose(R[pr], TOLD_PR_M ** 2 * factors[0] ** 2 * infl,
                                       rtol=1e-12)


def test_a_wrong_track_is_no_longer_softened_by_a_scale_of_its_own(watched):
    """A scale fed by the left track's rows alone (until the spawn) ends above the shared
    one; the Gaussian log-likelihood of its rows (closed form, SciPy) at the shared
    variances is below that at the variances its own scale would have given: the
    penalty that scale took off."""
    result, config, epochs = watched
    own = NoiseScale(config.noise_scale)
    shared = _shared_factors(config, epochs)
    lived, softened = [], 0.0
    for k, e in enumerate(epochs):
        if "left" not in e["elements"] or e["time_s"] > result.spawns[0][0]:
            break
        lived.append((own.variance_factor[ROW_KINDS[0]], shared[k][0][0] ** 2))
        record, kind, R, inflation, _ = e["seen"][e["scales"][e["elements"].index("left")]]
        factors = {kind_: f ** 2 for kind_, f in zip(ROW_KINDS, shared[k][0])}
        k2 = np.array([factors.get(kind_, 1.0) for kind_ in kind])
        k2_own = np.array([own.variance_factor.get(kind_, 1.0) for kind_ in kind])
        S_own = record.S + np.diag(R / k2 * (k2_own - k2))
        softened += multivariate_normal.logpdf(record.innov, cov=S_own) - \
            multivariate_normal.logpdf(record.innov, cov=record.S)
        own.variance_factor = factors
        own.seen(record, kind, R, inflation)       # its rows' own variances: R / k²
    assert len(lived) > 10
    own_k2, shared_k2 = lived[-1]
    assert own_k2 > shared_k2                   # measured: 7.7 against 4.4
    assert softened > 0.0                       # measured: 51 nats over 35 epochs


def test_innovations_csv_carries_the_written_hypothesis_factors(watched):
    """``innovations.csv``'s ``noise_scale`` of each epoch: the factors in effect
    (every hypothesis's, the single scale's), by kind."""
    result, config, epochs = watched
    inn = result.innovations
    shared = _shared_factors(config, epochs)
    assert inn["epoch"].nunique() == len(epochs)
    for j, kind in enumerate(ROW_KINDS):
        rows = inn[inn["kind"] == kind]
        expected = np.array([shared[k][0][j] for k in rows["epoch"]])
        np.testing.assert_array_equal(rows["noise_scale"].to_numpy(), expected)
