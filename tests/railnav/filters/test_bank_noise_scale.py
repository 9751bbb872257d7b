"""One noise scale for a bank of hypotheses (railnav/filters/noise_scale.py, "A bank":
`BankNoiseScale`, `MemberNoiseScale`).

Synthetic rows ``ν ~ N(0, a + λ b)`` through a rise (λ = 4, then 25 for a wrong
hypothesis): a bank of one gives a single `NoiseScale`'s factors and history to the bit,
fed by `add` or by a screen's record (`seen`, with a correlated-error inflation); a bank
of two counts only the feeder's rows (a single `NoiseScale` fed the feeder's rows alone,
computed apart), and its factors do not move within an epoch.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from railnav.filters.common import ROW_KINDS
from railnav.filters.bank_noise_scale import BankNoiseScale
from railnav.filters.noise_scale import CHI2_1_MEDIAN, NoiseScale, NoiseScaleConfig

#: Rows of a kind per epoch; their own variances ``b`` and prior parts ``a``.
ROWS = 8
OWN_VAR = np.linspace(9.0, 100.0, ROWS)
PRIOR_VAR = 0.3 * OWN_VAR
CONFIG = NoiseScaleConfig(window_epochs=30, z=2.0)


def _rows(rng, ratio: float) -> dict:
    """One epoch's ``{kind: (ν, a, b)}``, ``ν ~ N(0, a + ratio b)``."""
    return {k: (rng.standard_normal(ROWS) * np.sqrt(PRIOR_VAR + ratio * OWN_VAR), PRIOR_VAR,
                OWN_VAR) for k in ROW_KINDS}


def _ratio(epoch: int) -> float:
    return 4.0 if 40 <= epoch < 120 else 1.0


def _record(rng, ratio: float, factor: dict, inflation):
    """A screened epoch of pseudoranges then range rates, as a filter gives `seen`: its
    record (innovations, ``S`` = diag(a + R)), the rows' kinds, the update variances
    ``R = b k² inflation``."""
    kind = np.repeat(np.array(ROW_KINDS, dtype=object), ROWS)
    b = np.tile(OWN_VAR, 2)
    R = b * np.where(kind == ROW_KINDS[0], factor[ROW_KINDS[0]], factor[ROW_KINDS[1]]) * \
        (1.0 if inflation is None else inflation)
    nu = rng.standard_normal(2 * ROWS) * np.sqrt(np.tile(PRIOR_VAR, 2) + ratio * b)
    return SimpleNamespace(innov=nu, S=np.diag(np.tile(PRIOR_VAR, 2) + R)), kind, R


def _fed_alike(single, bank, member, rng, epochs: int, ratio) -> None:
    """Feed a single scale and a bank of one (`member` the feeder) the same rows by `add`
    (``ratio(epoch)``: the rows' variance ratio): the same factors at every epoch, the
    same history at the end, to the bit."""
    for epoch in range(epochs):
        rows = _rows(rng, ratio(epoch))
        single.begin_epoch()
        single.add(rows)
        bank.epoch(member)
        member.begin_epoch()
        member.add(rows)
        bank.end_epoch()
        assert member.variance_factor == single.variance_factor, epoch
    assert member.history == single.history


def test_a_bank_of_one_is_the_single_scale():
    """Fed by `add`: the same history and factors, to the bit, at every epoch of a rise
    and its fall."""
    single, bank = NoiseScale(CONFIG), BankNoiseScale(CONFIG)
    member = bank.member()
    _fed_alike(single, bank, member, np.random.default_rng(21), 200, _ratio)
    assert max(h[0] for h in single.history) > 1.5          # it rose, and was followed


def test_a_seeded_bank_is_the_seeded_single_scale():
    """`BankNoiseScale.seed` (a network start's scatter factors): every member has the
    seed at once, and a bank of one then follows a single scale seeded alike, to the bit,
    through the seed's floor and its fade (told right: the factors come back down)."""
    seed = {ROW_KINDS[0]: 6.0, ROW_KINDS[1]: 40.0}
    single, bank = NoiseScale(CONFIG), BankNoiseScale(CONFIG)
    member, other = bank.member(), bank.member()
    single.seed(seed)
    bank.seed(seed)
    assert member.variance_factor == other.variance_factor == single.variance_factor
    assert single.variance_factor == seed                       # in effect now (both >= 1)
    _fed_alike(single, bank, member, np.random.default_rng(23), 120, lambda _: 1.0)
    assert max(member.variance_factor.values()) < 2.0            # the seed faded


def test_a_bank_of_one_fed_by_the_screen_is_the_single_scale():
    """Fed by `seen` (a screen's record) with an inflation on the pseudoranges: the same
    factors as the single scale, to the bit."""
    single, bank = NoiseScale(CONFIG), BankNoiseScale(CONFIG)
    member = bank.member()
    rng = np.random.default_rng(22)
    inflation = np.where(np.arange(2 * ROWS) < ROWS, 2.5, 1.0)
    for epoch in range(200):
        record, kind, R = _record(rng, _ratio(epoch), single.variance_factor, inflation)
        single.begin_epoch()
        single.seen(record, kind, R, inflation)
        bank.epoch(member)
        member.begin_epoch()
        member.seen(record, kind, R, inflation)
        bank.end_epoch()
        assert member.variance_factor == single.variance_factor, epoch
    assert member.history == single.history
    assert max(h[0] for h in single.history) > 1.5


def test_only_the_feeder_counts_and_every_member_has_its_factors():
    """Two members, the feeder changing every 25 epochs; the other one's rows are a wrong
    hypothesis's (λ = 25). The bank's factors equal a single `NoiseScale` fed the feeder's
    rows alone; a member made late (a child) has them at once; both members' history is
    the same; the wrong rows alone would have risen far higher."""
    bank = BankNoiseScale(CONFIG)
    members = [bank.member(), bank.member()]
    alone, wrong_alone = NoiseScale(CONFIG), NoiseScale(CONFIG)
    rng = np.random.default_rng(23)
    for epoch in range(200):
        if epoch == 100:
            members[1] = bank.member()                        # a child, born now
        feeder = (epoch // 25) % 2
        rows = [_rows(rng, _ratio(epoch)), _rows(rng, 25.0)]
        right = rows[0] if feeder == 0 else rows[1]
        bank.epoch(members[feeder])
        for m, r in zip(members, rows):
            m.begin_epoch()
            m.add(r)
        bank.end_epoch()
        alone.add(right)
        wrong_alone.add(rows[1])
        assert members[0].variance_factor == alone.variance_factor, epoch
        assert members[1].variance_factor is members[0].variance_factor
    assert members[0].history[100:] == members[1].history
    assert wrong_alone.variance_factor["pseudorange"] > \
        2.0 * members[0].variance_factor["pseudorange"]


def test_the_factors_hold_through_an_epoch():
    """A feeder's rows of an epoch move the factors only at its end: a member that builds
    its rows after the feeder's was seen has the epoch's factors."""
    bank = BankNoiseScale(CONFIG)
    first, second = bank.member(), bank.member()
    rng = np.random.default_rng(24)
    for epoch in range(100):
        bank.epoch(first)
        first.begin_epoch()
        first.add(_rows(rng, 9.0))
        second.begin_epoch()                       # after the feeder's rows (one by one)
        second.add(_rows(rng, 9.0))
        bank.end_epoch()
    assert first.history == second.history
    assert first.history[-1][0] > 1.5


def test_without_a_feeder_nothing_enters():
    """An epoch without a feeder (none given, or its filter without GNSS rows) leaves the
    window as it is."""
    bank, single = BankNoiseScale(CONFIG), NoiseScale(CONFIG)
    member = bank.member()
    rng = np.random.default_rng(25)
    for epoch in range(120):
        rows = _rows(rng, 9.0)
        fed = epoch % 3 != 0
        bank.epoch(member if fed else None)
        member.add(rows)
        bank.end_epoch()
        if fed:
            single.add(rows)
        assert member.variance_factor == single.variance_factor
    assert not member.feeding
    assert member.variance_factor["pseudorange"] > 1.5


def test_a_restart_forgets_the_window():
    """After `BankNoiseScale.restart` the factors are 1 and the rows after it alone count:
    a fresh single scale fed those rows, to the bit; the members keep their history."""
    bank = BankNoiseScale(CONFIG)
    member = bank.member()
    rng = np.random.default_rng(26)
    for _ in range(60):
        bank.epoch(member)
        member.begin_epoch()
        member.add(_rows(rng, 25.0))
        bank.end_epoch()
    assert member.variance_factor["pseudorange"] > 5.0
    bank.restart()
    assert member.variance_factor == dict.fromkeys(ROW_KINDS, 1.0)
    fresh = NoiseScale(CONFIG)
    for _ in range(60):
        rows = _rows(rng, 4.0)
        bank.epoch(member)
        member.begin_epoch()
        member.add(rows)
        bank.end_epoch()
        fresh.add(rows)
        assert member.variance_factor == fresh.variance_factor
    assert len(member.history) == 120


def test_upper_bound_with_equal_weights_is_the_sign_test_order_statistic():
    """`NoiseScale.upper_bound`, equal weights: the ``ceil(n/2 + z √n / 2)``-th smallest
    ``q`` of the window (``q`` recomputed from the rows, `row_ratios`' closed form);
    inf with too few rows."""
    scale = NoiseScale(CONFIG)
    rng = np.random.default_rng(5)
    assert scale.upper_bound(ROW_KINDS[0]) == math.inf            # nothing seen
    own = np.ones(ROWS)
    q = []
    for _ in range(12):
        nu = rng.standard_normal(ROWS) * 3.0
        scale.add({ROW_KINDS[0]: (nu, np.zeros(ROWS), own)})
        q.append(nu ** 2 / CHI2_1_MEDIAN)
    q = np.concatenate(q)
    k = math.ceil(q.size / 2 + CONFIG.z * math.sqrt(q.size) / 2)
    assert scale.upper_bound(ROW_KINDS[0]) == np.sort(q)[k - 1]
    assert scale.upper_bound(ROW_KINDS[1]) == math.inf            # no rows of that kind


def _fed(rng, ratio: float, epochs: int = 30) -> NoiseScale:
    scale = NoiseScale(CONFIG)
    for _ in range(epochs):
        scale.add({ROW_KINDS[0]: (rng.standard_normal(ROWS) * np.sqrt(ratio * OWN_VAR),
                                  np.zeros(ROWS), OWN_VAR)})
    return scale


def test_restart_above_the_fixes_own_scale():
    """`BankNoiseScale.restart_above`: a bank whose rows said λ = 9 restarts (factors 1,
    window empty) against fixes whose rows say λ = 1 (their upper bound below 9), not
    against fixes that say λ = 9 too."""
    rng = np.random.default_rng(8)
    for own_ratio, restarts in ((1.0, True), (9.0, False)):
        bank = BankNoiseScale(CONFIG)
        member = bank.member()
        for _ in range(30):
            bank.epoch(member)
            member.add({ROW_KINDS[0]: (rng.standard_normal(ROWS) * np.sqrt(9.0 * OWN_VAR),
                                       np.zeros(ROWS), OWN_VAR)})
            bank.end_epoch()
        before = bank.scale.variance_factor[ROW_KINDS[0]]
        own = _fed(rng, own_ratio)
        assert before > own.upper_bound(ROW_KINDS[0]) if restarts else \
            before <= own.upper_bound(ROW_KINDS[0])
        assert bank.restart_above(own) is restarts
        assert bank.scale.variance_factor[ROW_KINDS[0]] == (1.0 if restarts else before)
