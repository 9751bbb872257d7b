"""The settings of a network run's multiple hypotheses (`NetworkNavConfig`), one owner of
their defaults: read by `railnav.navigation.network_navigator` and the modules it drives,
and by ``railnav run --network`` (`railnav.commands.network_run`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from railnav.defaults import DEFAULT_CROSSING_RATE_PER_S
from railnav.errors import ConfigError

__all__ = ["NetworkNavConfig"]


@dataclass(frozen=True)
class NetworkNavConfig:
    """The multiple-hypothesis part of a network run (`railnav.navigation.hypotheses`:
    branching, merging, pruning; `railnav.navigation.network_weights`: the weights).

    Parameters
    ----------
    max_hypotheses : int
        Most live hypotheses after a cycle (>= 1).
    prune_probability : float
        Hypotheses below this probability are dropped, in [0, 1).
    merge_mahalanobis : float
        Hypotheses on one element and orientation closer than this in ``(s, v)`` (in σ of
        their summed covariances) are merged, >= 0 (0: never).
    crossing_rate_per_s : float
        ε >= 0: the rate at which the train leaves its track for a track abreast (a
        crossover the map lacks, or the map's own error), 1/s
        (`railnav.navigation.network_weights`).
    crossing_radius_m : float
        Hypotheses whose positions are within this horizontally (and that travel the same
        way) are abreast: the Markov prior moves probability between them, m > 0.
    min_mixing_weight : float
        IMM mixing weights below this are skipped, in [0, 1).
    start_radius_m : float
        A start without a known netelement takes every netelement within this of the
        first fix, m > 0.
    start_abreast_probability : float
        A start on a known netelement is also one on the netelements abreast of it (as
        `crossing_radius_m` and `railnav.navigation.network_weights.abreast` define them),
        whose hypotheses together carry this prior probability, in [0, 1); 0: the known
        netelement only, as a told start was taken before
        (`railnav.navigation.network_start`, which gives its effect).
    continuous_evidence : bool
        Count the accelerometer pseudo-observation's likelihood in the weights (the
        curvature a switch's branch or a wrong ``s`` puts on it is the evidence inertial
        filters have before GNSS tells the branches apart).
    hypotheses_every_s : float
        ``hypotheses.csv`` keeps the live hypotheses of one cycle per this interval, s > 0.
    split_sigma_m : float
        A hypothesis whose σ_s exceeds this may split into a Gaussian sum along ``s``
        (`railnav.navigation.s_split`), m > 0 (inf: never).
    split_accel_mps2 : float
        ... when the lateral acceleration its track would cause spreads by more than
        this over ``s ± 3σ_s``, m/s² >= 0.
    evidence_correlation_s : float
        τ >= 0 of the errors of the epochs' measurements, fixes or pseudoranges (fixes from
        a receiver without corrections: a bias wandering over a minute; code multipath):
        each epoch's evidence counts ``(1 − ρ)/(1 + ρ)``, ``ρ = e^{−Δt/τ}`` (Δt since the
        previous epoch; the first whole). For a first-order Gauss–Markov error of the
        declared variance σ² these shares sum to ``σ² 1ᵀ Σ⁻¹ 1``, exactly the information
        the sequence holds about a constant offset between two hypotheses (a parallel
        track), whatever the intervals (``tests/railnav/navigation/test_evidence_share.
        py``). When only part of a row's declared variance is correlated, the share
        under-counts (never over-counts) the evidence; when the correlated part is not in
        the declared variance at all (rows declared with their white σ alone) it may still
        over-count: declare the rows' whole variance (for pseudoranges, e.g. the
        ``additive`` σ model with the multipath's elevation term,
        ``benchmarks/bench_network_spawn_gnss.py --declared``). 0: white errors, every
        epoch counts whole. Simulated code multipath (σ 1-2 m/sin(el), τ 60 s, σ_pr 3 m;
        5 seeds, ``bench_network_spawn_gnss.py``): with white weights a run without a
        start (spawning off) was confidently wrong (P >= 0.99 on B) in 2 (σ 1 m) and 4
        (2 m) runs of 5, 89 and 161 of ~490 cycles; with the variance and τ declared, only
        where every hypothesis's filter broke down (seed 3), at the cost of the tracks
        4.5 m apart being told in 33-80 s at 1 m and rarely within the 96 s at 2 m; a
        wrong told start then keeps its prior (1 − ``start_abreast_probability``).
        Filters that inflate their pseudoranges for the same correlation
        (``NavigatorConfig.pseudorange_correlation_s`` > 0: the inertial and gnss-only
        filters, `railnav.filters.gnss_only_noise.pseudorange_inflation`) discount each
        epoch's pseudorange evidence by that share already; this one counts it again.
        Told τ that way instead (the same multipath at σ 1 m, 5 seeds,
        ``bench_parallel_evidence.py --filter-correlation``), seed 3's filters no longer
        break down (its LLR A−B stays within ±0.5 nat; −82.8 told here) and no run is
        confident on B (``bench_network_spawn_gnss.py --cases unknown``, spawning off),
        but the most probable netelement settles on the true track in 2 of the 5 96-s runs
        (at 77 and 86 s; told here, 4 of 5, 33-80 s), P(true) at the end 0.11-0.79. The
        LLRs at 96 s were +1.5, +2.0, 0.0, −0.1, +1.2 nat (told here: +2.8, +3.3, −82.8,
        +3.9, +3.0), against the closed form's +0.4 ± 0.4.
    fix_bias_sigma_m : float
        σ_b >= 0 of a Gauss–Markov bias (τ = ``evidence_correlation_s``) per horizontal
        axis of the fixes, besides their declared white error: each hypothesis estimates
        it, and the cross-track row's evidence is its exact predictive density, counted
        whole (`railnav.navigation.fix_bias`; stacked fix-only runs). 0: not modelled.
    stacked : bool
        Step fix-only runs all hypotheses at once (`railnav.navigation.stacked_fixes`),
        and propagate the other filters' hypotheses together
        (`railnav.navigation.hypothesis_step.EngineStepper`, `ekf.stacked`); False:
        filter object by filter object through the engine (the same numbers: fix-only
        runs ~10× slower, a bank of inertial filters 0-8 % slower).
    spawn : bool
        Start new hypotheses from the fix when no live one agrees with the fixes
        (`railnav.navigation.spawning`), only when the network itself explains the
        window's fixes, and never from a dead-reckoned fix. On by default; runs without
        position fixes test and spawn from each GNSS epoch's own single-point fix
        (`railnav.navigation.spp_epochs`). On the four real Brussels logs as given it
        spawns nothing
        (before the dead-reckoning rule: once, on log_28554 at 238.8 s, from a
        ``PROPAGATED`` fix 24 m from 88_L_2013, the route then not navigable; before the
        network rule, 22 times); with the fixes degraded to single-point quality (5 seeds
        per log) once in four of log_29083's five runs (no truth epochs there; routes
        navigable) and never on the others, every per-epoch netelement figure the same as
        without spawning; with their bias modelled too (``fix_bias_sigma_m`` 2 m), once
        in all five of log_29083's runs, never on the others. False: the test runs (the
        ``status`` column), nothing is spawned.
    spawn_window_epochs : int
        Fix epochs in the window of that test, >= 0 (0: no test, no status column).
    spawn_p_value : float
        New hypotheses are started from the fix when that test's tail probability falls
        below this, in (0, 1).
    spawn_probability : float
        The probability the new hypotheses carry together when spawned, in (0, 1).
    """

    max_hypotheses: int = 16
    prune_probability: float = 1e-7
    merge_mahalanobis: float = 0.5
    crossing_rate_per_s: float = DEFAULT_CROSSING_RATE_PER_S
    crossing_radius_m: float = 10.0
    min_mixing_weight: float = 1e-6
    start_radius_m: float = 30.0
    start_abreast_probability: float = 0.01
    continuous_evidence: bool = True
    hypotheses_every_s: float = 1.0
    split_sigma_m: float = 5.0
    split_accel_mps2: float = 0.02
    evidence_correlation_s: float = 0.0
    fix_bias_sigma_m: float = 0.0
    stacked: bool = True
    spawn: bool = True
    spawn_window_epochs: int = 5
    spawn_p_value: float = 1e-6
    spawn_probability: float = 0.5

    def __post_init__(self) -> None:
        if not (isinstance(self.max_hypotheses, int) and self.max_hypotheses >= 1):
            raise ConfigError(f"max_hypotheses must be an integer >= 1, got "
                              f"{self.max_hypotheses!r}")
        if not (isinstance(self.spawn_window_epochs, int) and self.spawn_window_epochs >= 0):
            raise ConfigError(f"spawn_window_epochs must be an integer >= 0, got "
                              f"{self.spawn_window_epochs!r}")
        checks = {"prune_probability": lambda v: 0.0 <= v < 1.0,
                  "merge_mahalanobis": lambda v: v >= 0.0,
                  "crossing_rate_per_s": lambda v: v >= 0.0,
                  "crossing_radius_m": lambda v: v > 0.0,
                  "min_mixing_weight": lambda v: 0.0 <= v < 1.0,
                  "start_radius_m": lambda v: v > 0.0,
                  "start_abreast_probability": lambda v: 0.0 <= v < 1.0,
                  "hypotheses_every_s": lambda v: v > 0.0,
                  "split_sigma_m": lambda v: v > 0.0,
                  "split_accel_mps2": lambda v: v >= 0.0,
                  "evidence_correlation_s": lambda v: v >= 0.0,
                  "fix_bias_sigma_m": lambda v: v >= 0.0,
                  "spawn_p_value": lambda v: 0.0 < v < 1.0,
                  "spawn_probability": lambda v: 0.0 < v < 1.0}
        for name, ok in checks.items():
            value = getattr(self, name)
            finite = math.isfinite(value) or name == "split_sigma_m"
            if not (isinstance(value, (int, float)) and finite and ok(value)):
                raise ConfigError(f"{name}: invalid value {value!r}")
