"""What a filter run keeps: decimated states, innovation statistics, smoother data.

Everything is stored as NumPy arrays appended per span (never Python objects per step),
concatenated once when a result is made. Discrete-update innovations are ragged (each
epoch has its own number of components): they are kept flat with the epoch number of
each component.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.packing import diagonal_indices
from ekf.update import UpdateRecord

__all__ = ["FilterResult", "SmootherData", "Recorder", "concatenate_results"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SmootherData:
    """Per-step quantities the RTS smoother needs (kept when smoothing is on).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time of each step's start, s.
    x_filt, P_filt : ndarray, shapes (N, n), (N, n(n+1)/2)
        Filtered state at each step start (after all measurements at that sample).
    x_next, P_next : ndarray, shapes (N, n), (N, n(n+1)/2)
        Prediction to the next sample.
    Phi : ndarray, shape (N, n*n)
        Transition of each step, row by row.
    """

    t: Array
    x_filt: Array
    P_filt: Array
    x_next: Array
    P_next: Array
    Phi: Array


@dataclass(frozen=True)
class FilterResult:
    """Output of a run (or of one streamed chunk).

    Attributes
    ----------
    layout : StateLayout
    t : ndarray, shape (K,)
        Times of the stored (decimated) states, s.
    x : ndarray, shape (K, n)
        Filtered state at those times.
    P_diag : ndarray, shape (K, n)
        Diagonal of its covariance.
    P : ndarray, shape (K, n(n+1)/2) or None
        Full packed covariance, when asked for.
    t_c, innov_c, nis_c : ndarray, shapes (K,), (K, n_c), (K,)
        Continuous-measurement innovations and NIS at the stored times.
    nis_c_sum, nis_c_count : float, int
        Sum and number of the continuous NIS over ALL steps (not decimated).
    t_d : ndarray, shape (E,)
        Times of the discrete updates.
    nis_d, log_lik_d : ndarray, shape (E,)
        Whole-update NIS and log-likelihood.
    m_d, accepted_d : ndarray of int, shape (E,)
        Number of components, and of accepted ones.
    epoch_of, innov_d, s_d, accepted : ndarray, shape (M,)
        Per component of every update: epoch number, innovation, ``S_ii``, accepted.
    smoother : SmootherData or None
    x_final, P_final : ndarray, shapes (n,), (n, n)
        The state and covariance at the end of the run (prior at the last sample, or
        posterior if an update happened there).
    n_steps : int
        Steps taken (every step, stored or not).
    """

    layout: StateLayout
    t: Array
    x: Array
    P_diag: Array
    P: Array | None
    t_c: Array
    innov_c: Array
    nis_c: Array
    nis_c_sum: float
    nis_c_count: int
    t_d: Array
    nis_d: Array
    log_lik_d: Array
    m_d: Array
    accepted_d: Array
    epoch_of: Array
    innov_d: Array
    s_d: Array
    accepted: Array
    smoother: SmootherData | None
    x_final: Array
    P_final: Array
    n_steps: int = 0

    def to_frame(self) -> "pd.DataFrame":
        """States and standard deviations at the stored times: columns ``t_s``,
        ``<name>``, ``sigma_<name>`` for every state component (units of the state)."""
        import pandas as pd  # only at this boundary: the engine itself needs NumPy only
        data = {"t_s": self.t}
        for i, name in enumerate(self.layout.names):
            data[name] = self.x[:, i]
        for i, name in enumerate(self.layout.names):
            data[f"sigma_{name}"] = np.sqrt(self.P_diag[:, i])
        return pd.DataFrame(data)

    def innovations_frame(self) -> "pd.DataFrame":
        """Discrete-update innovations, one row per component: ``t_s``, ``epoch``,
        ``innovation``, ``sigma`` (``√S_ii``), ``accepted``."""
        import pandas as pd
        return pd.DataFrame({"t_s": self.t_d[self.epoch_of] if self.t_d.size else np.zeros(0),
                             "epoch": self.epoch_of, "innovation": self.innov_d,
                             "sigma": np.sqrt(self.s_d), "accepted": self.accepted})


#: `ekf.packing.diagonal_indices` of each state size, computed once (read-only arrays).
_diagonal = functools.lru_cache(maxsize=8)(diagonal_indices)


@dataclass
class Recorder:
    """Accumulates a run's history span by span (see :class:`FilterResult`)."""

    layout: StateLayout
    store_every: int = 1
    full_covariance: bool = False
    smoothing: bool = False
    _parts: dict[str, list[Array]] = field(default_factory=dict)
    #: Per discrete update: ``(t, nis, log_likelihood, m, accepted count)``, Python
    #: scalars (one array per field is made by `result`, not five per update).
    _updates: list[tuple] = field(default_factory=list)
    nis_c_sum: float = 0.0
    nis_c_count: int = 0
    n_steps: int = 0

    def _add(self, key: str, value: Array) -> None:
        self._parts.setdefault(key, []).append(value)

    def _get(self, key: str, shape_tail: tuple[int, ...], dtype=float) -> Array:
        parts = self._parts.get(key)
        if not parts:
            return np.zeros((0,) + shape_tail, dtype=dtype)
        if len(parts) == 1:               # one span (a streamed chunk): no copy needed
            return parts[0]
        return np.concatenate(parts, axis=0)

    def steps(self, first: int, t: Array, out) -> None:
        """Record a span of steps whose global indices start at ``first``.

        ``t`` (N,) are the step start times; ``out`` is a
        :class:`~ekf.propagate.StepOutputs`.
        """
        self.n_steps += t.size
        every = self.store_every
        # the steps whose global index is a multiple of store_every; copies when decimated
        # (a view would keep the whole span's outputs alive with the stored rows)
        keep = slice(None) if every == 1 else slice((-first) % every, None, every)
        take = (lambda a: a) if every == 1 else (lambda a: a[keep].copy())
        self._add("t", take(t))
        self._add("x", take(out.x_filt))
        P_filt = take(out.P_filt)
        self._add("P_diag", P_filt[:, _diagonal(self.layout.size)])
        if self.full_covariance:
            self._add("P", P_filt)
        self._add("innov_c", take(out.innov))
        if out.nis.size:
            self._add("nis_c", take(out.nis))
            self.nis_c_sum += float(np.add.reduce(out.nis))     # np.sum's reduction
            self.nis_c_count += int(out.nis.size)
        if self.smoothing:
            for key in ("x_filt", "P_filt", "x_next", "P_next", "Phi"):
                self._add("s_" + key, getattr(out, key))
            self._add("s_t", t)

    def update(self, t: float, record: UpdateRecord) -> None:
        """Record one discrete update at time ``t``."""
        self._updates.append((t, record.nis, record.log_likelihood, record.innov.size,
                              np.count_nonzero(record.accepted)))
        self._add("innov_d", record.innov)
        self._add("s_d", record.S.diagonal().copy())
        self._add("accepted", record.accepted)

    def _update_arrays(self) -> tuple[Array, Array, Array, Array, Array]:
        """``t_d, nis_d, log_lik_d`` (float) and ``m_d, accepted_d`` (int) of the updates."""
        columns = tuple(zip(*self._updates)) or ((),) * 5
        return (np.array(columns[0], dtype=float), np.array(columns[1], dtype=float),
                np.array(columns[2], dtype=float), np.array(columns[3], dtype=int),
                np.array(columns[4], dtype=int))

    def result(self, x_final: Array, P_final: Array) -> FilterResult:
        """The recorded history as a :class:`FilterResult`."""
        n = self.layout.size
        n_p = n * (n + 1) // 2
        smoother = None
        if self.smoothing:
            smoother = SmootherData(t=self._get("s_t", ()), x_filt=self._get("s_x_filt", (n,)),
                                    P_filt=self._get("s_P_filt", (n_p,)),
                                    x_next=self._get("s_x_next", (n,)),
                                    P_next=self._get("s_P_next", (n_p,)),
                                    Phi=self._get("s_Phi", (n * n,)))
        n_c = self._parts["innov_c"][0].shape[1] if self._parts.get("innov_c") else 0
        t_d, nis_d, log_lik_d, m_d, accepted_d = self._update_arrays()
        return FilterResult(
            layout=self.layout, t=self._get("t", ()), x=self._get("x", (n,)),
            P_diag=self._get("P_diag", (n,)),
            P=self._get("P", (n_p,)) if self.full_covariance else None,
            t_c=self._get("t", ()), innov_c=self._get("innov_c", (n_c,)),
            nis_c=self._get("nis_c", ()), nis_c_sum=self.nis_c_sum,
            nis_c_count=self.nis_c_count, t_d=t_d, nis_d=nis_d, log_lik_d=log_lik_d,
            m_d=m_d, accepted_d=accepted_d,
            epoch_of=np.repeat(np.arange(m_d.size), m_d), innov_d=self._get("innov_d", ()),
            s_d=self._get("s_d", ()), accepted=self._get("accepted", (), bool),
            smoother=smoother, x_final=np.array(x_final), P_final=np.array(P_final),
            n_steps=self.n_steps)


def concatenate_results(results: "list[FilterResult]") -> FilterResult:
    """One :class:`FilterResult` from consecutive streamed chunks (epoch numbers renumbered).

    Parameters
    ----------
    results : list of FilterResult
        In stream order, same layout (as :meth:`ekf.CdFilter.stream` yields them).

    Returns
    -------
    FilterResult
        Arrays concatenated; ``x_final``/``P_final`` of the last chunk; smoother data kept
        only if every chunk has it.
    """
    if not results:
        raise ValueError("no results to concatenate")
    first, last = results[0], results[-1]

    def cat(name: str) -> Array:
        parts = [getattr(r, name) for r in results]
        filled = [p for p in parts if p.shape[0]]   # an empty chunk may lack trailing sizes
        return np.concatenate(filled or parts[:1], axis=0)

    offsets = np.cumsum([0] + [r.t_d.size for r in results[:-1]])
    epoch_of = np.concatenate([r.epoch_of + off for r, off in zip(results, offsets)])
    smoother = None
    if all(r.smoother is not None for r in results):
        smoother = SmootherData(**{f: np.concatenate([getattr(r.smoother, f) for r in results])
                                   for f in ("t", "x_filt", "P_filt", "x_next", "P_next", "Phi")})
    return FilterResult(
        layout=first.layout, t=cat("t"), x=cat("x"), P_diag=cat("P_diag"),
        P=cat("P") if first.P is not None else None, t_c=cat("t_c"), innov_c=cat("innov_c"),
        nis_c=cat("nis_c"), nis_c_sum=float(sum(r.nis_c_sum for r in results)),
        nis_c_count=int(sum(r.nis_c_count for r in results)), t_d=cat("t_d"),
        nis_d=cat("nis_d"), log_lik_d=cat("log_lik_d"), m_d=cat("m_d"),
        accepted_d=cat("accepted_d"), epoch_of=epoch_of, innov_d=cat("innov_d"),
        s_d=cat("s_d"), accepted=cat("accepted"), smoother=smoother,
        x_final=last.x_final, P_final=last.P_final,
        n_steps=int(sum(r.n_steps for r in results)))
