"""A bank's epoch done K-wise (`railnav.filters.epochs_together.observations_together`:
`gnss_obs.epoch.prepare_epochs`, `railnav.filters.common.gnss_rows_together`,
`railnav.filters.fault_detection.screen_together`) against each filter's own
``observations`` call, one by one, on a second, identical set of filters: the rows, the
screen's decisions and records, the update's rows and the jump covariance, to the bit.

The epochs are real simulated ones (`curvy`, 3-m pseudoranges); the hypotheses sit on a
line and its parallels (−30, −4.5, +4.5 m: `trackmodel.offset.offset_track`) and at
different distances along it, one with a tight prior. One satellite's pseudorange carries
a 25-m fault in some epochs: the tight hypothesis rejects it (then excludes its channel)
while the loose ones keep using it; a 300-m receiver clock jump later is declared by the
tight hypothesis only.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ekf.series import EpochRows
from ekf.update import discrete_update
from gnss_obs.epoch import prepare_epoch, prepare_epochs
from railnav.filters.epochs_together import observations_together
from railnav.filters.protocol import make_filter
from railnav.filters.row_sets import (influence_gains, innovation_covariance,
                                      innovation_covariances)
from railnav.navigation.navigator import trip_samples
from railnav.navigation.state_conversion import converted
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track
from trackmodel.offset import offset_track

#: Offsets of the hypotheses' tracks from the line (m) and along it (m).
HYPOTHESES = ((-30.0, 0.0), (-4.5, 3.0), (0.0, 0.0), (0.0, 12.0), (4.5, -2.0))
#: The hypothesis with a tight prior (it rejects the faulted satellite).
TIGHT = 2
#: Clock-bias σ of the tight and of the other priors, m.
SIGMA_CLOCK_TIGHT_M, SIGMA_CLOCK_LOOSE_M = 0.5, 100.0
#: The injected pseudorange fault (m) and the epochs it is in.
FAULT_M, FAULT_EPOCHS = 25.0, range(4, 10)
#: A receiver clock jump on every pseudorange (m) from this epoch on (the tight hypothesis
#: declares it; the loose ones' clock σ covers it).
JUMP_M, JUMP_EPOCH = 300.0, 11
EPOCHS = range(2, 14)
TRIP_S = 15.0


@pytest.fixture(scope="module")
def bank():
    base = read_track(TRACKS_DIR / "double_a.csv")
    scenario = replace(get_scenario("curvy"), duration_s=TRIP_S, sigma_pseudorange_m=3.0)
    trip = simulate_trip(scenario, track=base, seed=1)
    config = navigator_config_for(scenario)
    gnss = trip_samples(trip.sensor_data(), config).gnss
    faulty = gnss.epochs[0].meas["sv"][0]
    for e in FAULT_EPOCHS:
        meas = gnss.epochs[e].meas
        pr = np.array(meas["pseudorange_m"], dtype=float)
        pr[meas["sv"] == faulty] += FAULT_M
        meas["pseudorange_m"] = pr
    for e in range(JUMP_EPOCH, len(gnss.epochs)):
        meas = gnss.epochs[e].meas
        meas["pseudorange_m"] = np.asarray(meas["pseudorange_m"], dtype=float) + JUMP_M
    tracks = [offset_track(base, d) if d else base for d, _ in HYPOTHESES]
    line = make_filter(base, config, gnss)
    x_true = line.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))[0]
    return {"base": base, "config": config, "gnss": gnss, "tracks": tracks, "line": line,
            "x_true": x_true, "truth_t": np.asarray(trip.truth.time_s, dtype=float),
            "faulty": faulty}


def _filters(bank):
    return [make_filter(track, bank["config"], bank["gnss"]) for track in bank["tracks"]]


def _priors(bank, filters, epoch: int):
    """Each hypothesis's prior at GNSS epoch `epoch`: the truth there brought onto its
    track, moved along it, with a loose or tight clock."""
    line = bank["line"]
    i = int(np.argmin(np.abs(bank["truth_t"] - bank["gnss"].time_s[epoch])))
    P_line = line.initial_covariance(sigma_s_m=1.0, sigma_v_mps=0.1)
    out = []
    for k, (filt, (_, along_m)) in enumerate(zip(filters, HYPOTHESES)):
        x = converted(line, filt, bank["x_true"][i], P_line)[0].copy()
        x[filt.layout.index("s")] += along_m
        P = filt.initial_covariance(sigma_s_m=1.0, sigma_v_mps=0.1)
        c = filt.layout.index("clock_bias")
        P[c, c] = (SIGMA_CLOCK_TIGHT_M if k == TIGHT else SIGMA_CLOCK_LOOSE_M) ** 2
        out.append((x, P))
    return out


def _parts(rows):
    """The update rows and jump covariance of an ``observations`` result."""
    jump = None
    if isinstance(rows, EpochRows):
        rows, jump = rows.observations, rows.jump_covariance
    return rows, jump


def _posterior(rows, x, P):
    """The discrete update of the prior with an ``observations`` result (its jump
    covariance added first, as `railnav.navigation.hypothesis_step.EngineStepper` adds it)."""
    rows, jump = _parts(rows)
    x_post, P_post, _ = discrete_update(x, P if jump is None else P + jump, rows)
    return x_post, P_post


def _assert_same_rows(a, b):
    (rows_a, jump_a), (rows_b, jump_b) = _parts(a), _parts(b)
    assert (jump_a is None) == (jump_b is None)
    if jump_a is not None:
        np.testing.assert_array_equal(jump_a, jump_b)
    for name in ("innov", "H", "R", "groups", "x"):
        np.testing.assert_array_equal(getattr(rows_a, name), getattr(rows_b, name),
                                      strict=True)
    assert len(rows_a) == len(rows_b)
    for one_a, one_b in zip(rows_a, rows_b):
        assert one_a.model is one_b.model
        for name in ("z", "R", "p"):
            np.testing.assert_array_equal(getattr(one_a, name), getattr(one_b, name),
                                          strict=True)


def _assert_same_screen(fa, fb):
    ea, eb = fa.screen.last, fb.screen.last
    for name in ("keys", "innov", "S", "status", "fault_probability"):
        np.testing.assert_array_equal(getattr(ea, name), getattr(eb, name), strict=True)
    assert ea.clock_jump_m == eb.clock_jump_m or (np.isnan(ea.clock_jump_m)
                                                  and np.isnan(eb.clock_jump_m))
    np.testing.assert_array_equal(fa.rows.rows_sv[-1], fb.rows.rows_sv[-1], strict=True)
    np.testing.assert_array_equal(fa.rows.rows_kind[-1], fb.rows.rows_kind[-1], strict=True)
    assert set(fa.screen._channels) == set(fb.screen._channels)
    for key, ch in fa.screen._channels.items():
        other = fb.screen._channels[key]
        assert (ch.excluded, ch._cusum, list(ch._failures)) == \
            (other.excluded, other._cusum, list(other._failures))
        np.testing.assert_array_equal(ch._influence, other._influence)


def test_bank_epoch_equals_each_filter_alone(bank):
    """Every epoch of EPOCHS: K-wise and one by one give the same rows, screen records,
    channel states, update rows and posterior; the faulted satellite is rejected (or its channel
    excluded) by the tight hypothesis while another hypothesis uses it; the clock jump is
    declared (an `ekf.EpochRows` with its covariance) by the tight one only."""
    together, alone = _filters(bank), _filters(bank)
    split = jumps = 0
    for e in EPOCHS:
        priors = _priors(bank, together, e)
        found = observations_together(together, e, priors)
        expected = [f.observations(e, x, P) for f, (x, P) in zip(alone, priors)]
        for fa, fb, a, b, (x, P) in zip(together, alone, found, expected, priors):
            _assert_same_rows(a, b)
            _assert_same_screen(fa, fb)
            for post_a, post_b in zip(_posterior(a, x, P), _posterior(b, x, P)):
                np.testing.assert_array_equal(post_a, post_b, strict=True)
        key = f"{bank['faulty']}/pseudorange"
        status = [dict(zip(f.screen.last.keys, f.screen.last.status)).get(key)
                  for f in together]
        if status[TIGHT] in ("rejected", "excluded") and "used" in status:
            split += 1
        declared = [np.isfinite(f.screen.last.clock_jump_m) for f in together]
        if declared[TIGHT] and sum(declared) == 1:
            assert isinstance(found[TIGHT], EpochRows)
            jumps += 1
    assert split >= 3 and jumps >= 1


def test_prepare_epochs_equals_prepare_epoch_per_guess(bank):
    """`prepare_epochs` at guesses on every hypothesis's track, plus an unknown guess
    (the origin) and one 200 km up, and one guess alone (shape (1, 3)): each guess's
    prepared satellites equal its own `prepare_epoch` (then masked as `GnssEpochs.prepare`
    masks), field by field."""
    gnss = bank["gnss"]
    filters = _filters(bank)
    e = 5
    guesses = [f.rows.receiver_part(x)[1:4] for f, (x, _) in zip(filters,
                                                                   _priors(bank, filters, e))]
    guesses += [np.zeros(3), guesses[0] * (1.0 + 2e5 / np.linalg.norm(guesses[0]))]
    found = prepare_epochs(gnss.epochs[e], gnss.config, r_rx_e=np.array(guesses),
                           klobuchar=gnss.klobuchar, transmit=gnss.transmit[e])
    for guess, one in zip(guesses, found):
        alone = prepare_epoch(gnss.epochs[e], gnss.config, r_rx_e=guess,
                              klobuchar=gnss.klobuchar, transmit=gnss.transmit[e])
        for name, value in vars(alone).items():
            np.testing.assert_array_equal(getattr(one, name), value, strict=True)
    assert np.isnan(found[-2].elevation).all() and np.isfinite(found[0].elevation).all()
    single = prepare_epochs(gnss.epochs[e], gnss.config, r_rx_e=np.array(guesses[:1]),
                            klobuchar=gnss.klobuchar, transmit=gnss.transmit[e])
    alone = prepare_epoch(gnss.epochs[e], gnss.config, r_rx_e=guesses[0],
                          klobuchar=gnss.klobuchar, transmit=gnss.transmit[e])
    assert len(single) == 1                         # one guess of shape (1, 3)
    for name, value in vars(alone).items():
        np.testing.assert_array_equal(getattr(single[0], name), value, strict=True)
    masked = gnss.prepare_together(e, np.array(guesses[:2]))
    for guess, one in zip(guesses[:2], masked):
        assert len(one) and np.all(one.elevation >= gnss.elevation_mask_rad)
        np.testing.assert_array_equal(one.sat_pos_e, gnss.prepare(e, guess).sat_pos_e)


def test_stacked_row_arithmetic_equals_each_filter_alone():
    """`innovation_covariances` and `influence_gains` of filters with different row counts
    (stacked by shape): ``H P Hᵀ + diag(R)``, ``H P`` and ``solve(S, H P)`` of each, to
    the bit, and `innovation_covariance` of one filter alone the same."""
    rng = np.random.default_rng(3)
    rows, gains = [], []
    for m in (6, 6, 4, 6, 1):
        H, A = rng.normal(size=(m, 7)), rng.normal(size=(7, 7))
        P, R = A @ A.T + np.eye(7), rng.uniform(1.0, 9.0, m)
        rows.append((H, P, R))
    for (H, P, R), (S_k, HP) in zip(rows, innovation_covariances(rows)):
        np.testing.assert_array_equal(S_k, H @ P @ H.T + np.diag(R), strict=True)
        np.testing.assert_array_equal(HP, H @ P, strict=True)
        for alone, stacked in zip(innovation_covariance(H, P, R), (S_k, HP)):
            np.testing.assert_array_equal(alone, stacked, strict=True)
        gains.append((H, S_k, P))
    for (H, S_k, P), K_t in zip(gains, influence_gains([(S_k, H @ P) for H, S_k, P in gains])):
        np.testing.assert_array_equal(K_t, np.linalg.solve(S_k, H @ P))
