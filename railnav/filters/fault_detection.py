r"""Satellite fault detection and exclusion (FDE) of a filter's GNSS rows, at the prior.

`RowScreen` looks at every GNSS epoch's rows before the filter's update, with the prior
``(x, P)`` of that epoch, and decides which rows the update uses:

1. **Receiver clock jump** (`railnav.filters.clock_jump`): a common offset of the admitted
   channels' pseudoranges, with a consistent residual, is a step of the receiver clock; the
   clock bias then gets the jump's variance and no satellite is blamed.
2. **Fault hypothesis of each row** (Herasimov et al. 2018, SEEDS.md §3; `ekf.outliers`):
   normal ``ν ~ N(0, S_ii)`` or a fault, uninformative about the state, ``ν ~ N(0, κ² S_ii)``,
   with a prior fault probability ``p`` per row and epoch; the posterior fault probability
   ``π`` of each row is recorded; a row with ``π > decision_probability`` is *rejected*
   (not used at this epoch).
3. **Exclusion and re-admission, per channel** (a channel is one satellite's pseudorange,
   or its range rate: a code fault leaves the Doppler usable; `railnav.filters.fault_channels`).
   A channel is *excluded* when it failed `exclusion_failures` times within its last
   `exclusion_window` epochs, or when its **drift test** fires: a two-sided CUSUM
   (Page 1954) of its normalized innovations ``r = ν/√S_ii`` (`drift_allowance` δ,
   `drift_threshold` h, in σ), each increment clipped at the row test's threshold so that
   one gross outlier never excludes alone. The CUSUM catches slow ramps, whose innovations
   stay at 1–3σ for many epochs while the filter follows them. On a drift exclusion the
   prior covariance gets the outer product of what the channel's used rows had pulled
   into the state during the CUSUM run, so the other satellites can pull it back. An excluded
   channel's innovations are still computed at each prior; it is re-admitted after
   `readmission_passes` consecutive passes of the row test whose mean is consistent with
   zero (a ramp still running passes single rows now and then, not this).

**Inflated rows** (`RowScreen.screen`'s ``inflation``: the constrained filter's
pseudoranges told errors correlated over τ have the variance ``f σ²`` in the update,
``f = (1+ρ)/(1−ρ)``, ρ = exp(−Δt/τ), `railnav.filters.gnss_only_noise.pseudorange_inflation`).
``f`` says how little a run of correlated errors tells; one epoch's error still has σ².
A fault-free row's innovation ``ν = e − H δx`` (``δx`` the prior's error, covariance ``P``)
has the variance ``S₀ = H P Hᵀ + σ²`` (at most: a prior pulled towards the satellite's
earlier, correlated errors has ``Cov(e, H δx) ≥ 0``), not ``S = H P Hᵀ + f σ²``, whose
row test would sit at ``3.73 √S``, up to ×11 wider (τ 60 s standing at 1 Hz; ×6.3 at
20 s). So the row test, its failures and the clock-jump test use ``r = ν/√S₀ᵢᵢ``
(`railnav.filters.row_sets.own_covariance`). The channel's sums (CUSUM, re-admission
mean) add ``ν/√Sᵢᵢ``: over ``n ≫ τ/Δt`` epochs a sum of correlated errors has the
variance ``n f σ²`` (the long-run variance ``f`` models), the CUSUM's design at ``S``;
at ``S₀`` a 1σ multipath bias lasting 60 s passes ``h = 9`` in ~15 s. Measured on curvy,
tactical, 1000 s, seeds 1–5 (34535 pseudorange rows; s37screen): multipath σ 1 m τ 60 s,
filter told τ 60 s, 2 rows not used with the sums at ``S``, 4854 (14 %, exclusions) at
``S₀`` (told 20 s: 2 and 4293; white errors told 20 s: 3 and 2040); the row test alone
expects 6.6. The update uses ``f σ²`` (the influence gains its ``S``); `EpochScreen.S`
(``innovations.csv``'s ``sigma``) is the update's. A row the screen uses has
``|ν| <= 3.73 √S₀`` and passes the update's χ² row gate (3.89σ at ``S >= S₀``).

Rows are screened by their mode (`SCREEN_MODES`): ``channel`` as above; ``row``, the row
test alone (GNSS fixes: a fix's error is no satellite's history); ``pass``, recorded and
used. Rows of one group (a fix's rows) are used together: one failing rejects them all.

**Evaluated once.** The screen evaluates every row at the prior (each `ekf.Observation`'s
model: its compiled rows) and hands the used ones to the update as an
`ekf.update.EvaluatedObservations`, which the update takes as they are. A new kind of row
(odometer, balise, attitude, zero speed) needs nothing more than its `ekf.MeasurementModel`
(scalar rows, variances ``R``) and its place in `railnav.filters.fix_rows.stack_epoch_rows`
with a label, a kind and a screen mode: it is then evaluated, screened and updated on the
same path as the GNSS rows.

Each row gets a status, ``used``, ``rejected`` or ``excluded`` (the row on which a channel
becomes excluded is marked ``excluded``), and its fault probability, written to
``innovations.csv`` (`railnav.navigation.result`). `RowScreen.last` keeps the latest epoch's
innovations and their full covariance (the network navigator compares hypotheses on the rows
they all saw and some used: `railnav.navigation.bank`).

Default parameters: ``p = 0.01``, ``κ = 10``, decision ½ give the gate
``|ν| > 3.73 √S`` (`ekf.fault_threshold`), a little tighter than the navigator's χ² row gate
at 0.9999 (3.89σ), so a fault-free row is rejected with probability 1.9e-4; three failures
in five epochs exclude (a fault-free channel: ~1e-10 per epoch); the CUSUM with
``δ = 0.35``, ``h = 9`` has an in-control run length of ~2500 epochs per channel
(Siegmund's approximation ``(e^{2δ(h+1.166)} − 2δ(h+1.166) − 1)/(2δ²)``, halved for two
sides) and detects a 2σ mean shift in ~6 epochs; ten consecutive passes re-admit
(10 s at 1 Hz). (δ, h) were chosen on 0.5 m/s ramps on each of the 7 satellites of `curvy`
over seeds 1–3 and checked on seeds 4–6: the largest pull was 2.97σ in both sets, at
0.4–0.6 % fault-free rows not used; (0.5, 8) gave 3.45σ and 0.1–0.3 %.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from ekf.series import EpochRows
from ekf.update import EvaluatedObservations, Observation
from railnav.filters.clock_jump import find_clock_jump
from railnav.filters.fault_channels import Channel
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.row_sets import (ROW_STATUSES, group_status, own_covariance, row_ids,
                                      subset_rows)
from railnav.filters.screens_together import screen_together

__all__ = ["RowScreen", "EpochScreen", "key_kind", "ROW_STATUSES", "SCREEN_MODES"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: How a row is screened (`RowScreen.screen`): with its channel's history, by the row
#: test alone, or passed through.
SCREEN_MODES = ("channel", "row", "pass")


def key_kind(key: str) -> str:
    """The kind of a row from its key ``"<sv>/<kind>"`` (`EpochScreen.keys`)."""
    return key.rsplit("/", 1)[-1]


@dataclass(frozen=True, eq=False)
class EpochScreen:
    """One screened epoch.

    Attributes
    ----------
    keys : ndarray of str, shape (m,)
        ``"<sv>/<kind>"`` of each row.
    innov : ndarray, shape (m,)
        Innovations at the prior, m or m/s.
    S : ndarray, shape (m, m)
        Their covariance ``H P Hᵀ + R`` (after a clock jump's variance was added).
    status : ndarray of str, shape (m,)
    fault_probability : ndarray, shape (m,)
    clock_jump_m : float
        The common pseudorange offset declared a clock jump, m (NaN: none).
    """

    keys: np.ndarray
    innov: Array
    S: Array
    status: np.ndarray
    fault_probability: Array
    clock_jump_m: float

    @property
    def used(self) -> npt.NDArray[np.bool_]:
        """Rows given to the update."""
        return self.status == ROW_STATUSES[0]


@dataclass
class RowScreen:
    """Screens each epoch's GNSS rows at the prior (module docstring).

    Parameters
    ----------
    config : FaultDetectionConfig or None
        None: every row is used (the innovations are still recorded).
    clock_index : int or None
        Index of the receiver clock bias state (m) in the filter's layout; None: no clock
        jump test.
    observer : callable(EpochScreen, kind, R, inflation), optional
        Called with each screened epoch, its rows' kinds, variances and correlated-error
        inflation (`screen`'s; None: 1): `railnav.filters.noise_scale.NoiseScale.seen`.
    """

    config: FaultDetectionConfig | None
    clock_index: int | None = None
    observer: object = None
    epochs: list[EpochScreen] = field(default_factory=list)
    _sv: list[np.ndarray] = field(default_factory=list)
    _kind: list[np.ndarray] = field(default_factory=list)
    _channels: dict[str, Channel] = field(default_factory=dict)
    _n_states: int = 0
    _clip_value: float | None = None

    @property
    def last(self) -> EpochScreen | None:
        """The latest screened epoch (None before the first)."""
        return self.epochs[-1] if self.epochs else None

    def screen(self, observations: list[Observation], sv: np.ndarray, kind: np.ndarray,
               x: Array, P: Array, *, modes: np.ndarray | None = None,
               groups: np.ndarray | None = None, inflation: Array | None = None
               ) -> list[Observation] | EpochRows:
        """The rows of one epoch the update should use.

        Parameters
        ----------
        observations : list of ekf.Observation
            The epoch's rows (scalar rows, diagonal ``R``), in the order of `sv` / `kind`.
        sv, kind : ndarray of str, shape (m,)
            Satellite and kind (`railnav.filters.common.ROW_KINDS`) of each row.
        x : ndarray, shape (n,)
            Prior state.
        P : ndarray, shape (n, n)
            Prior covariance.
        modes : ndarray of str, shape (m,), optional
            `SCREEN_MODES` of each row (default ``channel``).
        groups : ndarray of int, shape (m,), optional
            Rows of one group >= 0 are used together or not at all (-1: no group).
        inflation : ndarray, shape (m,), optional
            The factor each row's variance ``R`` carries for errors correlated from epoch
            to epoch (`railnav.filters.gnss_only_noise.pseudorange_inflation`; default 1):
            the update uses ``R``, the row tests the row's own ``R / inflation``
            (module docstring, "Inflated rows").

        Returns
        -------
        list of ekf.Observation, or ekf.EpochRows
            The used rows (an `ekf.update.EvaluatedObservations`: evaluated at ``x``, so
            the update does not evaluate them again); an `ekf.EpochRows` with the
            clock-jump covariance when a jump was declared.
        """
        return screen_together([self], [(observations, sv, kind, modes, groups, inflation)],
                               [(x, P)])[0]

    def _start(self, sv, kind, x: Array, P: Array, nu: Array, H: Array, S: Array,
               modes, R: Array | None = None, inflation: Array | None = None) -> dict:
        """`screen` up to the row tests: the rows' keys, the clock-jump test (its
        covariance ``Q`` and ``S`` with it), the normalized innovations and modes; with
        `inflation` (and the rows' variances `R`), the tests' covariance ``S₀`` with the
        rows' own variances (``r`` of the row test, ``r_drift`` of the channels' sums at
        the update's ``S``: module docstring, "Inflated rows")."""
        self._n_states = x.size
        # "<sv>/<kind>" of each row: the object arrays' elementwise str concatenation
        keys = np.asarray(sv, dtype=object) + "/" + np.asarray(kind, dtype=object) \
            if len(sv) else np.zeros(0, dtype=object)
        Q = np.zeros(P.shape, dtype=P.dtype)      # np.zeros_like(P), without its wrapper
        S0 = S if inflation is None else own_covariance(S, R, inflation)
        noise = R if inflation is None or R is None else R / inflation     # S0's own part
        jump = self._clock_jump(keys, kind, nu, S0, noise) if nu.size else None
        if jump is not None:
            Q[self.clock_index, self.clock_index] = jump[1]
            jump_S = H @ Q @ H.T
            S = S + jump_S
            S0 = S if inflation is None else S0 + jump_S
        r = nu / np.sqrt(S0.diagonal()) if nu.size else nu     # (np.diag's view of it)
        r_drift = r if inflation is None or not nu.size else nu / np.sqrt(S.diagonal())
        modes = np.full(keys.size, SCREEN_MODES[0], dtype=object) if modes is None else \
            np.asarray(modes, dtype=object)
        return {"keys": keys, "Q": Q, "jump": jump, "S": S, "r": r, "r_drift": r_drift,
                "modes": modes}

    def _rows_used(self, pending: dict, prob: Array, groups, H: Array, R: Array,
                   P: Array) -> None:
        """`screen` from the fault probabilities `prob` of `pending`'s rows (`_start`;
        None without a configuration) to the used rows: statuses, exclusions (their
        contamination into ``Q``, and ``S`` again), into `pending`."""
        status, prob, newly_excluded = self._decide(pending["keys"], pending["r"],
                                                    pending["modes"], prob,
                                                    pending["r_drift"])
        if groups is not None:
            status = group_status(status, np.asarray(groups))
        Q = pending["Q"]
        for key in newly_excluded:   # what the channel pulled in before it was caught
            delta = self._channels[key].contamination()
            Q += np.outer(delta, delta)
        if newly_excluded:
            pending["S"] = H @ (P + Q) @ H.T + np.diag(R)
        pending.update(status=status, prob=prob, used=status == ROW_STATUSES[0],
                       P_used=P + Q)

    def _record(self, pending: dict, observations, sv, kind, x: Array, nu: Array, H: Array,
                R: Array) -> list[Observation] | EpochRows:
        """The end of `screen`: the epoch recorded, the used rows for the update."""
        used, Q, jump = pending["used"], pending["Q"], pending["jump"]
        self.epochs.append(EpochScreen(pending["keys"], nu, pending["S"], pending["status"],
                                       pending["prob"],
                                       float(jump[0]) if jump is not None else np.nan))
        self._sv.append(np.asarray(sv, dtype=object))
        self._kind.append(np.asarray(kind, dtype=object))
        n_used = np.count_nonzero(used)      # every row (most epochs): the arrays as they are
        rows = EvaluatedObservations(observations, x=x, innov=nu, H=H, R=R,
                                     groups=row_ids(n_used)) if n_used == used.size else \
            EvaluatedObservations(subset_rows(observations, used), x=x, innov=nu[used],
                                  H=H[used], R=R[used], groups=row_ids(n_used))
        return EpochRows(rows, Q) if np.count_nonzero(Q) else rows

    def _clock_jump(self, keys: np.ndarray, kind: np.ndarray, nu: Array, S: Array,
                    noise: Array | None = None) -> tuple[float, float] | None:
        """(offset m, jump variance m²) of a declared receiver clock jump among the rows of
        the admitted channels (`railnav.filters.clock_jump.find_clock_jump`, with the rows'
        variances `noise` in `S`: None, always tested), or None."""
        cfg = self.config
        if cfg is None or cfg.clock_jump_false_alarm is None or self.clock_index is None:
            return None
        # no channel excluded (most epochs): every row admitted, without asking each
        admitted = None
        if any(ch.excluded for ch in self._channels.values()):
            channel = self._channel
            admitted = np.fromiter((not channel(k).excluded for k in keys), dtype=bool,
                                   count=keys.size)
            if admitted.all():
                admitted = None
        return find_clock_jump(cfg, kind, nu, S, admitted, noise)

    def _channel(self, key: str) -> Channel:
        if key not in self._channels:
            self._channels[key] = Channel(self.config, self._n_states)
        return self._channels[key]

    def _decide(self, keys: np.ndarray, r: Array, modes: np.ndarray, prob: Array | None,
                r_drift: Array) -> tuple[np.ndarray, Array, list[str]]:
        """Status and fault probability of each row from its normalized innovation `r`,
        its fault probability `prob` (`fault_probability` of ``r²``; None without a
        configuration) and its screen mode, and the channels excluded at this epoch;
        updates the channels with `r_drift` (`r`, or at the update's ``S``: `_start`)."""
        cfg = self.config
        status = np.full(keys.size, ROW_STATUSES[0], dtype=object)
        if cfg is None:
            return status, np.full(keys.size, np.nan), []
        prob = np.where(modes == SCREEN_MODES[2], np.nan, prob)
        failed = prob > cfg.decision_probability
        clip = self._clip()
        excluded = []
        channels, by_channel = self._channels, SCREEN_MODES[0]
        # Python floats and bools of the rows (the values float(r[i]), bool(failed[i]))
        for i, (key, mode, r_i, failed_i) in enumerate(zip(keys, modes, r_drift.tolist(),
                                                           failed.tolist())):
            if mode != by_channel:
                status[i] = ROW_STATUSES[1] if failed_i else ROW_STATUSES[0]
                continue
            ch = channels.get(key) or self._channel(key)
            if ch.excluded:
                status[i] = ROW_STATUSES[2]
                if ch.excluded_row(r_i, failed_i):
                    log.debug("channel %s re-admitted", key)
            elif ch.admitted_row(r_i, failed_i, clip):
                status[i] = ROW_STATUSES[2]
                excluded.append(key)
                log.debug("channel %s excluded", key)
            elif failed_i:
                status[i] = ROW_STATUSES[1]
        return status, prob, excluded

    def _clip(self) -> float:
        """``√nis_threshold``: the row test's threshold on ``|r|`` (computed once)."""
        if self._clip_value is None:
            self._clip_value = float(np.sqrt(self.config.nis_threshold))
        return self._clip_value

    def _influence_rows(self, pending: dict, H: Array, HP: Array
                        ) -> tuple[Array, Array] | None:
        """``S`` and ``H P`` of the used rows at the used covariance (`_rows_used`), whose
        gains `_add_influence` needs (None: no influence to add): `HP`, ``H P`` at the
        prior's ``P`` (`railnav.filters.row_sets.innovation_covariance`), as it is where
        every row is used and nothing was added to ``P`` (most epochs)."""
        used = pending["used"]
        n_used = np.count_nonzero(used)          # (bool counts: any/all without wrappers)
        if self.config is None or not n_used:
            return None
        S, P_used = pending["S"], pending["P_used"]
        if n_used == used.size:
            return S, HP if not np.count_nonzero(pending["Q"]) else H @ P_used
        return S[np.ix_(used, used)], H[used] @ P_used

    def _add_influence(self, keys: np.ndarray, used: npt.NDArray[np.bool_], nu: Array,
                       K_t: Array | None) -> None:
        """Each used row's correction ``K_i ν_i`` of this update, to its channel (rows
        screened without a channel keep none); ``K_t`` the used rows' ``Kᵀ``
        (`railnav.filters.row_sets.influence_gains` of `_influence_rows`), None: none."""
        if K_t is None:
            return
        every = K_t.shape[0] == used.size
        delta = K_t * (nu if every else nu[used])[:, None]     # row k: K_k ν_k
        get = self._channels.get
        for key, delta_k in zip(keys if every else keys[used], delta):
            channel = get(key)
            if channel is not None:
                channel.add_influence(delta_k)

    def clear_records(self) -> None:
        """Forget the recorded epochs (`frame`, `last`), keeping the channels' states (a
        streaming run writes the records as it goes)."""
        for records in (self.epochs, self._sv, self._kind):
            records.clear()

    def frame(self) -> pd.DataFrame:
        """All screened rows: ``screen_epoch, sv, kind, innovation, sigma, nis, status,
        fault_probability, clock_jump_m`` (the epoch's declared jump on each of its rows)."""
        if not self.epochs:
            return pd.DataFrame({c: [] for c in ("screen_epoch", "sv", "kind", "innovation",
                                                 "sigma", "nis", "status",
                                                 "fault_probability", "clock_jump_m")})
        sizes = [e.innov.size for e in self.epochs]
        var = np.concatenate([np.diag(e.S) for e in self.epochs])
        innov = np.concatenate([e.innov for e in self.epochs])
        return pd.DataFrame({
            "screen_epoch": np.repeat(np.arange(len(sizes)), sizes),
            "sv": np.concatenate(self._sv), "kind": np.concatenate(self._kind),
            "innovation": innov, "sigma": np.sqrt(var), "nis": innov ** 2 / var,
            "status": np.concatenate([e.status for e in self.epochs]),
            "fault_probability": np.concatenate([e.fault_probability for e in self.epochs]),
            "clock_jump_m": np.repeat([e.clock_jump_m for e in self.epochs], sizes)})
