"""The continuous–discrete EKF driver: spans of compiled steps, discrete updates between.

:class:`CdFilter` holds the current prior ``(x, P)`` at the current sample and the data
of that sample. :meth:`CdFilter.run` processes a whole :class:`~ekf.series.InputSeries`
with its discrete-update :class:`~ekf.series.Epoch` s and returns a
:class:`~ekf.history.FilterResult`; :meth:`CdFilter.stream` does the same chunk by chunk,
yielding one result per chunk (memory flat in the run length). Between two epochs the
steps run as ONE call of the compiled step loop (:mod:`ekf.propagate`); a span without
epochs (a GNSS outage) is just a longer call.

At an epoch sample the order is: discrete update of the prior (after adding the epoch's
jump covariance, :class:`~ekf.series.EpochRows`, when it gives one), then that sample's
continuous measurement and the step to the next sample.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np
import numpy.typing as npt
from scipy.linalg import lapack

from ekf.compiled import CompileOptions
from ekf.errors import FilterDivergedError, ModelError
from ekf.gating import Gate
from ekf.history import FilterResult, Recorder
from ekf.model import CdModel
from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import Backend, Propagator, StepOutputs
from ekf.series import Epoch, InputSeries, prior_and_rows
from ekf.step import StepOptions
from ekf.update import Observation, UpdateRecord, discrete_update

__all__ = ["FilterConfig", "CdFilter"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class FilterConfig:
    """Options of a :class:`CdFilter`.

    Attributes
    ----------
    step : ekf.step.StepOptions
    backend : {"auto", "compiled", "casadi", "casadi-jit"}
    compile : CompileOptions
    gate : Gate or None
        Gate of the discrete updates (None: accept everything).
    sequential : bool
        Process discrete updates scalar by scalar (diagonal ``R``).
    store_every : int
        Keep the filtered state every this many steps (>= 1).
    full_covariance : bool
        Keep the full packed covariance at the stored steps (else its diagonal).
    smoothing : bool
        Keep every step's data for :func:`ekf.smoother.rts_smooth` (memory ~
        ``8 (2 n² + 3 n)`` bytes per step).
    time_tol_s : float
        An epoch matches a sample when their times differ by at most this, s.
    """

    step: StepOptions = StepOptions()
    backend: Backend = "auto"
    compile: CompileOptions = CompileOptions()
    gate: Gate | None = None
    sequential: bool = False
    store_every: int = 1
    full_covariance: bool = False
    smoothing: bool = False
    time_tol_s: float = 1e-6

    def __post_init__(self) -> None:
        if self.store_every < 1:
            raise ModelError(f"store_every must be >= 1, got {self.store_every}")
        if not self.time_tol_s >= 0.0:
            raise ModelError(f"time_tol_s must be >= 0, got {self.time_tol_s}")


def _check_covariance(P: Array, where: str | Callable[[], str]) -> None:
    """Raise `FilterDivergedError` unless `P` is finite and positive definite; `where`
    (or what it returns: a message formatted only when needed) says where."""
    if np.count_nonzero(np.isfinite(P)) != P.size:       # (np.isfinite(P).all())
        raise FilterDivergedError(f"covariance became non-finite {_text(where)}")
    # LAPACK's Cholesky (the factor is not used: only whether it exists), without
    # np.linalg.cholesky's wrapper (~15 µs a call, one call per span)
    _, info = lapack.dpotrf(P, lower=True, clean=False, overwrite_a=False)
    if info != 0:
        raise FilterDivergedError(f"covariance lost positive definiteness {_text(where)}")


def _text(where: str | Callable[[], str]) -> str:
    return where if isinstance(where, str) else where()


def checked_prior(n: int, x0: npt.ArrayLike, P0: npt.ArrayLike) -> tuple[Array, Array]:
    """A prior as the engine starts from it: float copies, shapes ``(n,)`` and ``(n, n)``
    checked, ``P0`` positive definite and symmetrized (`CdFilter.reset`,
    `ekf.stacked.propagate_members`).

    Raises
    ------
    ModelError
        Wrong shapes.
    FilterDivergedError
        ``P0`` not finite or not positive definite.
    """
    x0, P0 = np.array(x0, dtype=float), np.array(P0, dtype=float)
    if x0.shape != (n,) or P0.shape != (n, n):
        raise ModelError(f"x0 must be ({n},) and P0 ({n}, {n}); got {x0.shape}, {P0.shape}")
    _check_covariance(P0, "in the initial covariance")
    return x0, 0.5 * (P0 + P0.T)


def step_data(propagator, chunk: InputSeries) -> Array:
    """The step data of a chunk's ``M − 1`` steps (``propagator.data.assemble`` of its
    samples but the last; `CdFilter.propagate`, `ekf.stacked.propagate_members`).

    With ``StepOptions.jacobian_window_s > 0`` the linearization input ``u_lin`` is the
    chunk's own (`ekf.series.InputSeries.u_lin`: railnav's drivers give the median over
    the whole window, across chunks) or, without it, the centred running median
    (`ekf.step.window_median`) of the chunk's own ``M`` samples (in `CdFilter`, the
    previous chunk's last sample and the new ones), shrinking within a half window of
    the chunk's ends.
    """
    t = chunk.t
    return propagator.data.assemble(chunk.u, chunk.p[:-1], chunk.z_c[:-1], t[1:] - t[:-1],
                                    chunk.q_c[:-1], chunk.r_c[:-1], t=chunk.t,
                                    u_lin=chunk.u_lin)


class CdFilter:
    """Continuous–discrete EKF of a :class:`~ekf.model.CdModel`.

    Parameters
    ----------
    model : CdModel
    config : FilterConfig

    Attributes
    ----------
    propagator : Propagator
        The compiled step loop (built once here).
    x : ndarray, shape (n,)
        Current state (prior at :attr:`t`).
    P : ndarray, shape (n, n)
    t : float
        Time of the current sample, s (NaN before the first sample).
    """

    def __init__(self, model: CdModel, config: FilterConfig = FilterConfig()) -> None:
        self.model, self.config = model, config
        self.propagator = Propagator(model, config.step, backend=config.backend,
                                     compile_options=config.compile)
        self.x = np.zeros(model.n)
        self.P = np.eye(model.n)
        self.t = float("nan")
        self._last: InputSeries | None = None
        self._step_index = 0
        self._last_outputs: StepOutputs | None = None

    def reset(self, x0: npt.ArrayLike, P0: npt.ArrayLike) -> None:
        """Start over from a prior (forgets the last sample).

        Parameters
        ----------
        x0 : array_like, shape (n,)
        P0 : array_like, shape (n, n)
            Symmetric positive definite.
        """
        self.x, self.P = checked_prior(self.model.n, x0, P0)
        self.t, self._last, self._step_index = float("nan"), None, 0

    def update(self, observations: Sequence[Observation], *, gate: Gate | None = None,
               sequential: bool | None = None) -> UpdateRecord:
        """Discrete update of the current prior (gate and mode default to the config's)."""
        gate = self.config.gate if gate is None else gate
        seq = self.config.sequential if sequential is None else sequential
        self.x, self.P, record = discrete_update(self.x, self.P, observations, gate=gate,
                                                 sequential=seq)
        return record

    def propagate(self, samples: InputSeries) -> StepOutputs:
        """Step through new samples (continuing from the last sample seen, or from the
        prior set by :meth:`reset`); return the per-step outputs of the new steps."""
        self._last_outputs = None
        self._advance(self._shape(samples), _Peekable(iter(())), Recorder(self.model.layout),
                      None)
        return self._last_outputs

    def run(self, samples: InputSeries, epochs: Iterable[Epoch], *, x0: npt.ArrayLike,
            P0: npt.ArrayLike, progress: Progress | None = None) -> FilterResult:
        """Filter a whole series.

        Parameters
        ----------
        samples : InputSeries
            ``M`` samples (``M − 1`` steps).
        epochs : iterable of Epoch
            Discrete updates, in time order, at sample times.
        x0 : array_like, shape (n,)
            Prior at the first sample.
        P0 : array_like, shape (n, n)
        progress : callable(done, total), optional
            Called after each span with the steps done and the total.

        Returns
        -------
        FilterResult
        """
        return next(self.stream([samples], epochs, x0=x0, P0=P0, progress=progress,
                                total=len(samples) - 1))

    def stream(self, chunks: Iterable[InputSeries], epochs: Iterable[Epoch], *,
               x0: npt.ArrayLike, P0: npt.ArrayLike, progress: Progress | None = None,
               total: int = 0) -> Iterator[FilterResult]:
        """Filter consecutive chunks, yielding each chunk's :class:`FilterResult`.

        ``epochs`` is consumed lazily; ``total`` (steps, optional) is passed to
        ``progress``. Each result's epoch numbers start at 0.
        """
        self.reset(x0, P0)
        pending = _Peekable(iter(epochs))
        for chunk in chunks:
            rec = Recorder(self.model.layout, self.config.store_every,
                           self.config.full_covariance, self.config.smoothing)
            self._advance(self._shape(chunk), pending, rec, progress, total)
            yield rec.result(self.x, self.P)
        if pending.peek() is not None:
            log.warning("epochs after the last sample were not used (first at t=%.6f s)",
                        pending.peek().t)

    def _shape(self, samples: InputSeries) -> InputSeries:
        m = self.model
        return samples.shaped(m.n_u, m.n_p, m.n_c, m.n_w)

    def _advance(self, chunk: InputSeries, epochs: "_Peekable", rec: Recorder,
                 progress: Progress | None, total: int = 0) -> None:
        """Steps from the current sample through ``chunk``, with updates at epochs."""
        t, d = self._steps_from_last(chunk)
        n_samples = t.size
        cursor = 0
        while True:
            stop = n_samples - 1
            epoch = epochs.peek()
            at = None if epoch is None else self._sample_of(epoch, t)
            if at is not None and at < n_samples:
                stop = at
            self._run_span(t, d, cursor, stop, rec)
            cursor = stop
            if progress is not None:
                progress(self._step_index, total)
            if at is None or at >= n_samples:
                break
            epochs.next()
            self.t = float(t[at])
            rec.update(self.t, self.update(self._rows_at(epoch)))
            if at == n_samples - 1:
                break
        last = len(chunk)
        self._last = chunk.slice(last - 1, last)
        self.t = float(t[-1])

    def _steps_from_last(self, chunk: InputSeries) -> tuple[Array, Array]:
        """The sample times from the last sample seen (if any) through `chunk`, and the
        step data between them (`step_data` of the joined samples)."""
        if self._last is None:
            return chunk.t, step_data(self.propagator, chunk)
        if chunk.t[0] <= self._last.t[-1]:
            raise ModelError("chunk times must continue after the previous chunk")
        joined = _joined_step_data(self.propagator.data, self._last, chunk)
        if joined is None:
            chunk = _concat(self._last, chunk)
            return chunk.t, step_data(self.propagator, chunk)
        return joined

    def _rows_at(self, epoch: Epoch) -> Sequence[Observation]:
        """The epoch's observations at the current prior, after adding its jump covariance
        (:class:`~ekf.series.EpochRows`) to the prior."""
        self.P, rows = prior_and_rows(self.P, epoch.observations_at(self.x, self.P))
        return rows

    def _sample_of(self, epoch: Epoch, t: Array) -> int | None:
        j = int(t.searchsorted(epoch.t - self.config.time_tol_s))   # (the method: no wrapper)
        if j >= t.size:
            return t.size  # after this chunk
        if abs(t[j] - epoch.t) > self.config.time_tol_s:
            if j == 0 and self._step_index == 0:
                raise ModelError(f"epoch t={epoch.t:.6f} s is before the first sample")
            raise ModelError(f"epoch t={epoch.t:.6f} s is not a sample time (nearest "
                             f"{t[min(j, t.size - 1)]:.6f} s): insert a sample there")
        return j

    def _run_span(self, t: Array, d: Array, start: int, stop: int, rec: Recorder) -> None:
        if stop <= start:
            return
        out = self.propagator.run(self.x, pack_sym(self.P), d[start:stop])
        self.x = out.x_next[-1].copy()
        self.P = unpack_sym(out.P_next[-1])
        _check_covariance(self.P, lambda: f"at t={t[stop]:.6f} s")
        rec.steps(self._step_index, t[start:stop], out)
        self._step_index += stop - start
        self._last_outputs = out


def _joined_step_data(data, last: InputSeries, chunk: InputSeries
                      ) -> tuple[Array, Array] | None:
    """The sample times and step data of `last` (the previous chunk's last sample) then
    `chunk`, both shaped: what ``step_data`` of ``_concat(last, chunk)`` gives (the same
    copies and the same step differences, so the same bits), written into one array in
    `ekf.step.StepData.assemble`'s column order without concatenating every field first
    (~15 µs a chunk; ``tests/ekf/test_cd_filter.py`` compares the two). None where a
    linearization input must be computed from the samples (a chunk without ``u_lin``):
    `_concat` and `step_data`."""
    if data.n_lin and (last.u_lin is None or chunk.u_lin is None):
        return None
    m = chunk.t.size                      # steps: from `last`'s sample and each of `chunk`'s
    d = np.empty((m, data.size))
    t_all = np.empty(m + 1)
    t_all[0], t_all[1:] = last.t[0], chunk.t
    n_u = data.n_u
    col = 0
    for first, rest, width in ((last.u, chunk.u, n_u), (None, chunk.u, n_u),
                               (last.p, chunk.p, data.n_p), (last.z_c, chunk.z_c, data.n_c),
                               (None, None, 1), (last.q_c, chunk.q_c, data.n_w),
                               (last.r_c, chunk.r_c, data.n_c),
                               (last.u_lin, chunk.u_lin, data.n_lin)):
        block = d[:, col:col + width]
        col += width
        if not width:                                       # (no u_lin, or no z_c, r_c)
            continue
        if rest is None:                                    # dt: np.diff of the times
            np.subtract(t_all[1:], t_all[:-1], out=block[:, 0])
        elif first is None:                                 # u_{k+1}: the chunk's rows
            block[...] = rest
        else:
            block[0] = first[0]
            block[1:] = rest[:-1]
    return t_all, d


def _concat(a: InputSeries, b: InputSeries) -> InputSeries:
    """`a`'s samples then `b`'s (``u_lin`` only when both have it)."""
    both = a.u_lin is not None and b.u_lin is not None
    return InputSeries(**{k: np.concatenate([getattr(a, k), getattr(b, k)], axis=0)
                          for k in ("t", "u", "q_c", "p", "z_c", "r_c")},
                       u_lin=np.concatenate([a.u_lin, b.u_lin], axis=0) if both else None)


class _Peekable:
    def __init__(self, it: Iterator[Epoch]) -> None:
        self._it, self._head, self._done = it, None, False

    def peek(self) -> Epoch | None:
        if self._head is None and not self._done:
            self._head = next(self._it, None)
            self._done = self._head is None
        return self._head

    def next(self) -> Epoch | None:
        head = self.peek()
        self._head = None
        return head
