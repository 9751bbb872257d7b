"""One adaptive noise scale (`railnav.filters.noise_scale`) for the hypotheses of a bank:
the network navigator's (`railnav.navigation.network_navigator`).

The scale is the receiver's and its surroundings', not a hypothesis's: every hypothesis's
rows of an epoch carry the same factors, and the rows of one hypothesis feed them, those
of the most probable before the epoch (its innovations at its prior, as a single filter's). A hypothesis on a wrong track
has large innovations; with a scale of its own (until 2026-12-07) its factors rose, its
rows' variances with them, and its likelihood was penalised less: it lived longer, and
its risen scale let rows back in (a 400-m wrong start of
``benchmarks/bench_network_spawn_gnss.py`` "recovered" so), while its rows re-sorted
its window each epoch. Weighting every hypothesis's rows by its probability would count
the same measurements several times in one window (its sign test takes them for
independent) and let the wrong tracks' rows raise the factors exactly when the bank is
unsure; the most probable hypothesis's alone are one set per epoch. Which hypothesis
feeds changes with the weights; branching, merging and pruning do not touch the window
(every hypothesis, born when it may, is a `MemberNoiseScale` of the one bank); a start
again after every hypothesis died forgets it (`BankNoiseScale.restart`), as a new run
would, and so does a spawn (`railnav.navigation.spawning`) when the scale is above what
the epochs' own single-point fixes say (`BankNoiseScale.restart_above`: their residuals'
scale, `railnav.navigation.spp_epochs`, which knows no hypothesis): the rows that raised
it were a wrong hypothesis's. A true wrong start then recovers as with a scale per
hypothesis (a 400-m one of ``benchmarks/bench_network_spawn_gnss.py``, whose rows raised
the factors of the right hypotheses spawned: within 10 m after 5-7 s, 8-13 s without
the restart, 5 seeds), while a σ told too small, which raises the fixes' scale as much,
keeps it: 3 tracks 4.5 m apart, pseudoranges 3 m told 1 m, 300 s, seeds 1-5, where a
restart at each spawn cost 99.8 -> 95.0 % of the cycles on the right netelement, none of
the 72 spawns (false ones: the fixes keep the told σ, `railnav.navigation.spp_epochs`)
restarted it (k² 3.5-7.5 against the fixes' upper bounds 8.7-18). A bank of one is the
single filter: the same factors, to the bit.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.filters.common import ROW_KINDS
from railnav.filters.noise_scale import NoiseScale, NoiseScaleConfig

__all__ = ["BankNoiseScale", "MemberNoiseScale"]

Array = npt.NDArray[np.float64]


class BankNoiseScale:
    """One `NoiseScale` for the hypotheses of a bank (module docstring): each
    hypothesis's filter has a `member`, whose factors are the bank's; the rows of one
    member per epoch, the feeder's (`epoch`), count, and they enter the window after
    every member's rows of the epoch were built (`end_epoch`).

    Parameters
    ----------
    config : NoiseScaleConfig or None
        None: the scale is 1 for good.
    """

    def __init__(self, config: NoiseScaleConfig | None) -> None:
        self.scale = NoiseScale(config)
        self._feeder: MemberNoiseScale | None = None
        self._parts: dict | None = None

    def member(self) -> "MemberNoiseScale":
        """The scale of a new hypothesis's filter."""
        return MemberNoiseScale(self)

    def restart(self) -> None:
        """Forget the window, the factors back to 1 (the bank's hypotheses were found
        lost: their rows were no measure of the receiver's noise)."""
        self.scale = NoiseScale(self.scale.config)

    def seed(self, variance_factor: dict[str, float]) -> None:
        """Seed the bank's factors at a start (`NoiseScale.seed`: the start's scatter
        factors, `railnav.navigation.start_scatter`)."""
        self.scale.seed(variance_factor)

    def restart_above(self, own: NoiseScale) -> bool:
        """At a spawn (`railnav.navigation.spawning`): `restart` when the pseudoranges'
        factor is above `own`'s upper confidence bound (`NoiseScale.upper_bound`; `own`
        the scale of the epochs' own single-point fixes, `railnav.navigation.spp_epochs`,
        from their residuals whatever the hypotheses): the rows that raised it were
        significantly noisier than the receiver's, a wrong hypothesis's. Whether it
        restarted."""
        kind = ROW_KINDS[0]
        if self.scale.variance_factor[kind] <= own.upper_bound(kind):
            return False
        self.restart()
        return True

    def epoch(self, feeder: "MemberNoiseScale | None") -> None:
        """Before an epoch: the member whose rows will count (None: none)."""
        self._feeder, self._parts = feeder, None

    def hold(self, member: "MemberNoiseScale", parts: dict) -> None:
        """The feeder `member`'s epoch (`NoiseScale.parts_seen`, `NoiseScale.parts_added`),
        kept for `end_epoch`."""
        if member is self._feeder:
            self._parts = parts

    def end_epoch(self) -> None:
        """After every member's rows of the epoch: the feeder's into the window, the
        factors updated (the next epoch's)."""
        if self._parts is not None:
            self.scale.take(self._parts)
        self._feeder = self._parts = None


class MemberNoiseScale:
    """A bank hypothesis's `NoiseScale` (`BankNoiseScale.member`): the bank's factors,
    its own `history`; its rows count when it is the bank's feeder."""

    def __init__(self, bank: BankNoiseScale) -> None:
        self.bank = bank
        #: ``k`` of each kind at each of its filter's epochs (`NoiseScale.history`).
        self.history: list[tuple[float, ...]] = []

    @property
    def config(self) -> NoiseScaleConfig | None:
        return self.bank.scale.config

    @property
    def variance_factor(self) -> dict[str, float]:
        """The bank's ``k²`` of each kind (`NoiseScale.variance_factor`)."""
        return self.bank.scale.variance_factor

    @property
    def feeding(self) -> bool:
        """Whether its rows count this epoch (`NoiseScale.feeding`)."""
        return self.bank._feeder is self and self.config is not None

    def begin_epoch(self) -> None:
        """`NoiseScale.begin_epoch`: the bank's factors into this member's `history`."""
        self.history.append(self.bank.scale.factors())

    def seen(self, record, kind: np.ndarray, R: Array, inflation: Array | None) -> None:
        """`NoiseScale.seen`, for the bank's `end_epoch` when feeding."""
        if self.feeding:
            self.bank.hold(self, self.bank.scale.parts_seen(record, kind, R, inflation))

    def add(self, rows: dict[str, tuple[Array, Array, Array]]) -> None:
        """`NoiseScale.add`, for the bank's `end_epoch` when feeding."""
        if self.feeding:
            self.bank.hold(self, NoiseScale.parts_added(rows))
