r"""An adaptive scale of the GNSS rows' measurement noise, per row kind (issue 14: "a
filter's σ is a promise").

A receiver's σ (``gnss_obs.MeasurementConfig``: σ/sin(el) with a C/N0 penalty, or what
the user told with ``--sigma-pr-m`` / ``--sigma-rr-mps``) may be too small: a simulated
1000-s curvy trip run as plain files (no ``scenario.json``: the real receiver's defaults,
whose Doppler σ at zenith is 14× below the simulator's) had 52 % of its GNSS rows
rejected, NEES 17.0 for 5 states and 40 restarts; told its σ, NEES 4.07. `NoiseScale`
multiplies the variances of each row kind (pseudorange, range rate; one factor per kind,
shared by the satellites, on top of each row's own elevation weighting) by ``k²``,
estimated from the filter's own innovations at the prior, by covariance matching on a
robust statistic.

**Estimate.** A row's innovation at the prior has the variance ``a + λ b``: ``a`` what the
filter's prior and the rows' other terms give (``H P Hᵀ``, the range rates' heading part;
a clock jump's variance), ``b`` the row's own declared variance (``R``, without the
correlated-error inflation, whose rows' single-epoch variance is ``b``:
`railnav.filters.fault_detection`, "Inflated rows") and λ the unknown ratio. Each row
gives ``q = (ν²/m₁ − a)/b``, ``m₁ = 0.4549`` the χ²₁ median: the λ at which its NIS
``ν²/(a + λ b)`` is at the median. Over the rows of one kind of the last
``window_epochs`` epochs, the NIS's weighted median is ``m₁`` exactly at the weighted
median of the ``q``: that is the covariance-matching estimate of λ, robust to any
minority of the weight (a faulty satellite, multipath on a few). The weight of a row is
its information ``1/b``: the state leans on the rows of small σ, and their consistency
is the state's. A scale with equal weights is not enough where the σ model's shape is
wrong: the simulator's σ is constant, the real receiver's default ``σ/sin(el)`` with a
C/N0 penalty (``b`` from 1 to 120 m² on the plain trip), and the equal-weight median
(σ factors 1.4 / 5) left the high satellites' rows, which carry the estimate, too
precise: NEES 16.4 on the 1000-s plain trip (its innovations consistent at the median),
against 6.0 with the weights.

**Test, not estimate.** The scale is not the median but its one-sided lower confidence
bound: the largest λ that leaves the weight ``W/2 + z √(Σw²)/2`` of the ``q`` above it
(the weighted sign test at ``z``: ``Σ w 1[NIS > m₁]`` has the mean ``W/2`` and the
variance ``Σw²/4`` when the σ are right). It exceeds 1 only when the rows' NIS are above
their median significantly more often than half the time; with the σ right it stays 1,
exactly (the rows' variances are then the told ones, to the bit). The price is a bias
low: at the default window (~1000 rows, ``n_eff = W²/Σw²`` ~700) the bound is the
``q``'s 43rd percentile, ~0.75 λ when ``a`` ≪ ``b``; it tends to λ as the window grows
(``tests/railnav/filters/test_noise_scale.py``). ``k² = min(max(λ, 1), k_max²)``: the
declared σ is a floor (a receiver's σ may be pessimistic; shrinking it is not what
honesty needs) and ``max_sigma_factor`` a ceiling. The scale of an epoch is the one
estimated from the epochs before it: a fault cannot inflate its own rows' variance.

**A fault.** A faulty satellite always above the median is its share of the weight: with
8 satellites from 15° to 80°, the highest is 23 % and moves the bound to the good rows'
upper 35 % at most (λ < 1.9 at ``a`` ≪ ``b``; 1.38 measured over 200 epochs), so a
30-m code step against its σ of 3 m stays 8σ and is rejected. On simulated 300-s curvy
trips with a 30-m step on G05 for 100 s (seeds 1-3), the step's rows were used in 0 of
100 epochs with the scale as without it; the pseudorange scale rose during the fault by
1.00-1.03 (told the σ) and from 2.5-3.4 to 3.5-3.7 (plain files, where the along-track
pull of the fault fell from 2.2-24.9σ to 0.8-2.0σ). A fault on more than
half the weight is no longer a fault of one satellite: the scale then says so.

`NoiseScale` is owned by each filter with GNSS rows (`railnav.filters.constrained`, the
rows scaled before its fault screen, which tests each row at its own scaled variance, fed
from the screen's record; `railnav.filters.gnss_only`, fed from its rows evaluated at the
prior); ``NavigatorConfig.noise_scale`` (`NoiseScaleConfig`, None: off). Position fixes
keep their σ (their class's σ, or the receiver's own estimate: another promise, with its
own screen). The scale in effect at each epoch is ``innovations.csv``'s ``noise_scale`` (σ
factor ``k``), and ``summary.json``'s ``statistics.noise_scale`` its final and largest.

**A start** from GNSS files (`railnav.navigation.initialization.first_fix`) has no
window yet: the first fixes' scatter (`railnav.navigation.start_scatter`) gives each
kind's variance factor (positions: pseudoranges; velocities: range rates), which
`NoiseScale.seed` puts in effect at once and keeps as a floor for half the window, then
fading to 1 as the window turns over (a plain-files curvy trip, 10 seeds: NEES at 5 s
64 -> 3.3, at 20 s 16.6 -> 3.2).
Told the right σ, the seed is 1 and nothing changes.

**A bank** of hypotheses (the network navigator's) shares one scale, fed by its most
probable hypothesis: `railnav.filters.bank_noise_scale`. The single-point fixes of its
spawn test have one of their own, fed by their residuals: `railnav.navigation.spp_epochs`.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError
from railnav.filters.gnss_rows import ROW_KINDS   # not .common: no engine (ekf.update) for a config

__all__ = ["NoiseScaleConfig", "NoiseScale",
           "CHI2_1_MEDIAN", "scale_bound",
           "row_ratios", "scaled_gnss_rows", "row_scales",
           "scale_statistics"]

Array = npt.NDArray[np.float64]

#: The median of χ²₁ (``scipy.stats.chi2.ppf(0.5, 1)``).
CHI2_1_MEDIAN = 0.454936423119572


@dataclass(frozen=True)
class NoiseScaleConfig:
    """The adaptive noise scale of the GNSS rows (module docstring).

    Attributes
    ----------
    window_epochs : int
        Epochs whose rows estimate the scale (default 120: two minutes at 1 Hz, ~1000
        rows of a kind with 8 satellites).
    z : float
        Significance of the sign test, in σ of its count (default 3.5: a one-sided false
        rise of 2.3e-4 per window of independent rows; on synthetic rows told right,
        8 satellites, 600 epochs, 100 seeds, no run rose, where z = 3 with a 60-epoch
        window rose in 13, by ≤ 1.10 in σ).
    max_sigma_factor : float
        The largest factor ``k`` on the σ (default 20: variances ×400).
    """

    window_epochs: int = 120
    z: float = 3.5
    max_sigma_factor: float = 20.0

    def __post_init__(self) -> None:
        if not (isinstance(self.window_epochs, int) and self.window_epochs >= 1):
            raise ConfigError(f"noise_scale.window_epochs must be an integer >= 1, got "
                              f"{self.window_epochs!r}")
        for name, low in (("z", 0.0), ("max_sigma_factor", 1.0)):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= low):
                raise ConfigError(f"noise_scale.{name} must be a finite number >= {low:g}, "
                                  f"got {value!r}")


def row_ratios(innov: Array, fixed_var: Array, own_var: Array) -> Array:
    """Each row's ``q = (ν²/m₁ − a)/b``: the variance ratio λ at which its NIS
    ``ν²/(a + λ b)`` is the χ²₁ median (module docstring).

    Parameters
    ----------
    innov : ndarray, shape (m,)
        Innovations at the prior ``ν``.
    fixed_var : ndarray, shape (m,)
        ``a``: their variance but the rows' own (``H P Hᵀ``, other terms).
    own_var : ndarray, shape (m,)
        ``b``: the rows' own declared variances (> 0).
    """
    return (np.square(innov) / CHI2_1_MEDIAN - fixed_var) / own_var


def scale_bound(q: Array, weight: Array, *, z: float, floor: float = -math.inf) -> float:
    """The one-sided lower confidence bound at `z` of the weighted median of `q`: the
    largest λ with ``Σ_{q >= λ} w >= W/2 + z √(Σ w²) / 2`` (W = Σ w; the weighted sign
    test's count, of variance ``Σ w² / 4`` when the σ are right), at least `floor`
    (`floor` when no λ has it: too few rows).

    Parameters
    ----------
    q : ndarray, shape (n,)
        `row_ratios` of a window's rows.
    weight : ndarray, shape (n,)
        Their weights (> 0; `NoiseScale`: the information ``1/b``).
    z : float
        In σ of the sign test's count.
    floor : float
        The result is at least this (without sorting when the bound is below it).

    Returns
    -------
    float
    """
    if not q.size:
        return floor
    need = _needed_weight(float(weight.sum()), float(np.dot(weight, weight)), z)
    if float(weight[q >= floor].sum()) < need:
        return floor                                  # not significant above the floor
    order = np.argsort(q)[::-1]                                 # q descending
    reached = np.cumsum(weight[order])
    j = int(np.searchsorted(reached, need))             # the first with that weight
    return max(float(q[order[j]]), floor) if j < q.size else floor


def _needed_weight(total: float, squares: float, z: float) -> float:
    """``W/2 + z √(Σw²)/2`` (`scale_bound`), less a relative 1e-12 for the sums' rounding
    (a window's running Σw² of no rows can be a rounding's −1e-17: taken as 0)."""
    return (0.5 * total + 0.5 * z * math.sqrt(max(squares, 0.0))) * (1.0 - 1e-12)


class NoiseScale:
    """The scale of each GNSS row kind, from the rows of the epochs before (module
    docstring).

    Parameters
    ----------
    config : NoiseScaleConfig or None
        None: the scale is 1 for good (nothing is kept).

    Attributes
    ----------
    variance_factor : dict of str to float
        ``k²`` of each kind (`railnav.filters.gnss_rows.ROW_KINDS`), in effect now.
    history : list of tuple of float
        ``k`` of each kind (in `ROW_KINDS`' order) at each epoch, in the order of
        `begin_epoch`'s calls (``innovations.csv``'s ``noise_scale``).
    """

    def __init__(self, config: NoiseScaleConfig | None) -> None:
        self.config = config
        self.variance_factor = dict.fromkeys(ROW_KINDS, 1.0)
        self.history: list[tuple[float, ...]] = []
        self._window = {kind: deque(maxlen=config.window_epochs if config else 1)
                        for kind in ROW_KINDS}
        # Σw, Σw², Σw[q >= 1] of each kind's window, kept as parts enter and leave, summed
        # again from the parts each time the window has turned over (no drift)
        self._sums = {kind: [0.0, 0.0, 0.0] for kind in ROW_KINDS}
        self._appended = dict.fromkeys(ROW_KINDS, 0)
        self._seed = dict.fromkeys(ROW_KINDS, 1.0)

    def seed(self, variance_factor: dict[str, float]) -> None:
        """Start from `variance_factor` (``k²`` of some kinds, ≥ 1; a start's evidence:
        `railnav.navigation.start_scatter`): in effect now, and a floor on the scale for
        half a window, which then falls linearly to 1 when the window has turned over once
        (its own evidence then a full window; held to the end, a plain-files curvy trip's
        NEES at 140 s over 10 seeds fell to 2.70, below the 99 % band's 2.80: the
        start's factor outlived its 10 epochs' evidence). Without a configuration, or at
        1, nothing changes."""
        if self.config is None:
            return
        top = self.config.max_sigma_factor ** 2
        for kind, factor in variance_factor.items():
            self._seed[kind] = min(max(float(factor), 1.0), top)
            self.variance_factor[kind] = max(self.variance_factor[kind], self._seed[kind])

    def _append(self, kind: str, part: tuple) -> None:
        """Add one epoch's `_window_part` of `kind` to its window and its sums."""
        window, sums = self._window[kind], self._sums[kind]
        if len(window) == window.maxlen:
            for j, old in enumerate(window[0][2:]):
                sums[j] -= old
        window.append(part)
        self._appended[kind] += 1
        if self._appended[kind] % window.maxlen == 0:
            sums[:] = [sum(p[j] for p in window) for j in (2, 3, 4)]
        else:
            for j, new in enumerate(part[2:]):
                sums[j] += new

    @property
    def feeding(self) -> bool:
        """Whether the rows given to `seen` and `add` count (a filter computes them only
        then): with a configuration."""
        return self.config is not None

    def factors(self) -> tuple[float, ...]:
        """``k`` of each kind (in `ROW_KINDS`' order), in effect now."""
        return tuple(math.sqrt(self.variance_factor[k]) for k in ROW_KINDS)

    def begin_epoch(self) -> None:
        """Record the factors in effect for the epoch about to be built (`history`)."""
        self.history.append(self.factors())

    def seen(self, record, kind: np.ndarray, R: Array, inflation: Array | None) -> None:
        """Add the screened epoch `record` (`railnav.filters.fault_detection.EpochScreen`:
        its innovations and update covariance ``S``, whose diagonal less the update
        variances `R` is ``a``) of rows of `kind`, whose own variances are `R` over their
        correlated-error `inflation` (None: 1) and this scale's factor, and update the
        scale (`RowScreen.observer`)."""
        if self.config is not None:
            self.take(self.parts_seen(record, kind, R, inflation))

    def add(self, rows: dict[str, tuple[Array, Array, Array]]) -> None:
        """Add one epoch's rows, ``{kind: (ν, a, b)}`` (`row_ratios`), and update the
        scale (a filter without a screen: `railnav.filters.gnss_only`)."""
        if self.config is not None:
            self.take(self.parts_added(rows))

    def parts_seen(self, record, kind: np.ndarray, R: Array, inflation: Array | None
                   ) -> dict:
        """`seen`'s epoch as each kind's window part (`take`), the scale unchanged."""
        fixed = np.diagonal(record.S) - R
        out = {}
        for k in ROW_KINDS:
            rows = kind == k
            f = self.variance_factor[k] if inflation is None else \
                inflation[rows] * self.variance_factor[k]
            own = R[rows] / f
            out[k] = _window_part(row_ratios(record.innov[rows], fixed[rows], own), own)
        return out

    @staticmethod
    def parts_added(rows: dict[str, tuple[Array, Array, Array]]) -> dict:
        """`add`'s epoch as each kind's window part (`take`)."""
        out = {}
        for k in ROW_KINDS:
            found = rows.get(k)
            out[k] = _window_part(row_ratios(*found), found[2]) if found is not None else \
                _window_part(np.zeros(0), np.ones(0))
        return out

    def take(self, parts: dict) -> None:
        """Add one epoch's window part of each kind (`parts_seen`, `parts_added`) and
        update the scale."""
        for k in ROW_KINDS:
            self._append(k, parts[k])
        self._update()

    def upper_bound(self, kind: str) -> float:
        """The one-sided upper confidence bound at ``z`` of the weighted median of
        `kind`'s window of ``q`` (`scale_bound` mirrored: the smallest λ with the weight
        ``W/2 + z √(Σw²)/2`` of the ``q`` at or below it); inf without a configuration
        or with too few rows."""
        if self.config is None or not self._window[kind]:
            return math.inf
        q, weight = self._window_rows(kind)
        return -scale_bound(-q, weight, z=self.config.z, floor=-math.inf)   # no rows: inf

    def _window_rows(self, kind: str) -> tuple[Array, Array]:
        """``q`` and the weights of every row in `kind`'s window (not empty)."""
        window = self._window[kind]
        return (np.concatenate([part[0] for part in window]),
                np.concatenate([part[1] for part in window]))

    def _update(self) -> None:
        cfg = self.config
        top = cfg.max_sigma_factor ** 2
        half = 0.5 * cfg.window_epochs
        for k in ROW_KINDS:
            floor = 1.0 + (self._seed[k] - 1.0) * min(max(
                (cfg.window_epochs - self._appended[k]) / half, 0.0), 1.0)
            total, squares, above = self._sums[k]
            if above < _needed_weight(total, squares, cfg.z):   # the sign test at 1: no
                self.variance_factor[k] = floor
                continue
            q, weight = self._window_rows(k)
            self.variance_factor[k] = min(max(scale_bound(q, weight, z=cfg.z, floor=1.0),
                                              floor), top)


def _window_part(q: Array, own_var: Array) -> tuple:
    """One epoch's rows in a window: ``q``, the weights ``1/b``, and their sums ``Σw``,
    ``Σw²`` and ``Σ w [q >= 1]`` (`NoiseScale._update`'s sign test at 1 needs no sort)."""
    w = 1.0 / own_var
    return q, w, float(w.sum()), float(np.dot(w, w)), float(w[q >= 1.0].sum())


def scaled_gnss_rows(rows: list, models, *, pseudorange_factor: float,
                     scale: NoiseScale) -> list:
    """GNSS rows (`ekf.Observation` s of `models`, a `railnav.filters.gnss_rows.GnssRows`)
    with the variances of each kind times `scale`'s factor, the pseudoranges' times
    `pseudorange_factor` too (the correlated-error inflation,
    `railnav.filters.gnss_only_noise.pseudorange_inflation`); other rows as they are."""
    factors = {models.pseudorange: pseudorange_factor * scale.variance_factor[ROW_KINDS[0]],
               models.range_rate: scale.variance_factor[ROW_KINDS[1]]}
    out = []
    for obs in rows:
        factor = factors.get(obs.model, 1.0)
        out.append(obs if factor == 1.0 else replace(obs, R=obs.R * factor))
    return out


def row_scales(history: list[tuple[float, ...]], epoch: Array, kind: Array) -> Array:
    """``innovations.csv``'s ``noise_scale``: each row's σ factor at its epoch
    (`NoiseScale.history` indexed by `epoch`), NaN for kinds not scaled or when the
    history does not cover the epochs."""
    epoch = np.asarray(epoch, dtype=np.intp)
    out = np.full(epoch.size, np.nan)
    if not history or (epoch.size and epoch.max() >= len(history)):
        return out
    table = np.asarray(history, dtype=float)
    kind = np.asarray(kind, dtype=object)
    for j, k in enumerate(ROW_KINDS):
        rows = kind == k
        out[rows] = table[epoch[rows], j]
    return out


def scale_statistics(innovations) -> dict:
    """``summary.json``'s ``statistics.noise_scale``: ``{kind: {"final", "max"}}`` of the
    σ factors in ``innovations.csv``'s ``noise_scale`` (empty without the column or its
    values)."""
    if "noise_scale" not in innovations or not len(innovations):
        return {}
    out = {}
    for kind in ROW_KINDS:
        scale = innovations.loc[innovations["kind"] == kind, "noise_scale"].dropna()
        if len(scale):
            out[kind] = {"final": float(scale.iloc[-1]), "max": float(scale.max())}
    return {"noise_scale": out} if out else {}
