"""Input sample series and discrete-update epochs: what the filter driver consumes.

Convention: everything is *per sample*. Sample ``k`` at time ``t_k`` carries the input
``u_k``, the parameters ``p_k`` and the continuous-measurement value ``z_c,k`` of the
step that starts at it (``t_k → t_{k+1}``); the last sample of a run only closes the last
step. A stream is a sequence of consecutive, non-overlapping :class:`InputSeries` chunks;
the filter remembers the last sample of a chunk to form the step into the next.

A discrete update (:class:`Epoch`) happens at a sample time, before that sample's
continuous measurement. An epoch between samples must first be made a sample (split the
step, interpolating the input). An epoch's callable may answer with :class:`EpochRows`
to add a jump covariance to the prior before the update (a state that jumped at the
epoch, recognised from the epoch's own measurements).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import numpy.typing as npt

from ekf.errors import ModelError
from ekf.update import Observation

__all__ = ["InputSeries", "Epoch", "EpochRows", "prior_and_rows"]

Array = npt.NDArray[np.float64]


def _finite(a: Array) -> bool:
    """``np.isfinite(a).all()`` (a count of the bool array: without ``all``'s wrapper)."""
    return np.count_nonzero(np.isfinite(a)) == a.size


def _rows(a: npt.ArrayLike | None, m: int, k: int, name: str) -> Array:
    if a is None:
        return np.zeros((m, k))
    a = np.asarray(a, dtype=float)
    if a.shape == (k,):               # one row for all samples: checked once, repeated
        if not _finite(a):
            raise ModelError(f"{name} has non-finite values")
        # a contiguous copy: ~0.6 µs for a chunk's 100 rows, where np.broadcast_to's view
        # costs ~8 µs and makes every later operation on it (checks, concatenations) slower
        return a[np.newaxis].repeat(m, axis=0)
    if a.shape != (m, k):
        raise ModelError(f"{name} must have shape ({m}, {k}) or ({k},), got {a.shape}")
    if not _finite(a):
        raise ModelError(f"{name} has non-finite values")
    return a


@dataclass(frozen=True)
class InputSeries:
    """``M`` consecutive input samples.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Sample times, s, strictly increasing.
    u : ndarray, shape (M, n_u)
        Input samples (e.g. IMU ``[f_b, omega_ib_b]`` in m/s², rad/s).
    p : ndarray, shape (M, n_p), optional
        Parameters of the step starting at each sample (default zeros).
    z_c : ndarray, shape (M, n_c), optional
        Continuous-measurement values (default zeros: a pseudo-observation).
    q_c : ndarray, shape (n_w,) or (M, n_w)
        Diagonal process-noise spectral density, [w]²·s (e.g. (m/s²)²·s).
    r_c : ndarray, shape (n_c,) or (M, n_c), optional
        Diagonal independent continuous-measurement noise density (default zeros).
    u_lin : ndarray, shape (M, n_u), optional
        The input at which each sample's continuous-measurement Jacobian is evaluated
        (`ekf.step.StepOptions.jacobian_window_s`). None: `ekf.cd_filter.step_data`
        computes it from the chunk's own samples (a driver that cuts one series into
        chunks gives it when a chunk's window must see samples beyond the chunk, as
        `railnav.navigation.loop.ChunkLoop` does across a stream's blocks).
    """

    t: Array
    u: Array
    q_c: Array
    p: Array | None = None
    z_c: Array | None = None
    r_c: Array | None = None
    u_lin: Array | None = None

    def shaped(self, n_u: int, n_p: int, n_c: int, n_w: int) -> "InputSeries":
        """A copy with every field checked and broadcast to ``(M, ·)``.

        Raises
        ------
        ModelError
            Wrong shapes, non-finite values, times not increasing, negative noise.
        """
        t = np.asarray(self.t, dtype=float).reshape(-1)
        m = t.size
        if not _finite(t) or np.count_nonzero(t[1:] - t[:-1] <= 0.0):   # (np.diff(t))
            raise ModelError("sample times must be finite and strictly increasing")
        fields = dict(t=t, u=_rows(self.u, m, n_u, "u"), p=_rows(self.p, m, n_p, "p"),
                      z_c=_rows(self.z_c, m, n_c, "z_c"), q_c=_rows(self.q_c, m, n_w, "q_c"),
                      r_c=_rows(self.r_c, m, n_c, "r_c"))
        if np.count_nonzero(fields["q_c"] < 0.0) or np.count_nonzero(fields["r_c"] < 0.0):
            raise ModelError("noise spectral densities must be >= 0")
        if self.u_lin is not None:
            u_lin = np.asarray(self.u_lin, dtype=float)
            if u_lin.shape != (m, n_u) or not _finite(u_lin):
                raise ModelError(f"u_lin must be finite, shape ({m}, {n_u}); got "
                                 f"{u_lin.shape}")
            fields["u_lin"] = u_lin
        return InputSeries(**fields)

    def __len__(self) -> int:
        return int(np.size(self.t))

    def slice(self, start: int, stop: int) -> "InputSeries":
        """Samples ``start:stop`` of a shaped series."""
        return InputSeries(t=self.t[start:stop], u=self.u[start:stop], q_c=self.q_c[start:stop],
                           p=self.p[start:stop], z_c=self.z_c[start:stop],
                           r_c=self.r_c[start:stop],
                           u_lin=None if self.u_lin is None else self.u_lin[start:stop])


@dataclass(frozen=True)
class Epoch:
    """A discrete update at one sample time.

    Attributes
    ----------
    t : float
        Time, s; must equal a sample time (within the driver's ``time_tol_s``).
    observations : sequence of Observation, or callable
        Stacked into one update (may be empty: an epoch without measurements). A callable
        ``observations(x, P) -> sequence of Observation`` is called with the prior at the
        epoch, when the update happens: for measurement rows whose parameters depend on
        the state (a linearization point, a satellite geometry computed at the prior).
    """

    t: float
    observations: Sequence[Observation] | Callable[[Array, Array], Sequence[Observation]] = \
        field(default_factory=tuple)

    def observations_at(self, x: Array, P: Array) -> "Sequence[Observation] | EpochRows":
        """The observations of this epoch, given the prior ``(x, P)`` at its time (or
        :class:`EpochRows` when the callable gives a jump covariance)."""
        obs = self.observations
        return obs(x, P) if callable(obs) else obs


@dataclass(frozen=True)
class EpochRows:
    """An epoch's observations with a jump of the state at the epoch.

    Attributes
    ----------
    observations : sequence of Observation
    jump_covariance : ndarray, shape (n, n), optional
        Added to the prior covariance before the update: the covariance of a jump of the
        state at the epoch (symmetric positive semi-definite; e.g. a receiver clock step,
        with one non-zero diagonal entry).
    """

    observations: Sequence[Observation]
    jump_covariance: Array | None = None

    def __post_init__(self) -> None:
        Q = self.jump_covariance
        if Q is not None:
            Q = np.asarray(Q, dtype=float)
            if Q.ndim != 2 or Q.shape[0] != Q.shape[1] or not np.all(np.isfinite(Q)):
                raise ModelError(f"jump_covariance must be a finite square matrix, got shape "
                                 f"{Q.shape}")
            if not np.allclose(Q, Q.T) or np.any(np.diag(Q) < 0.0):
                raise ModelError("jump_covariance must be symmetric with a diagonal >= 0")
            object.__setattr__(self, "jump_covariance", Q)


def prior_and_rows(P: Array, rows: "Sequence[Observation] | EpochRows"
                   ) -> "tuple[Array, Sequence[Observation]]":
    """The prior covariance an epoch's rows update, and the rows: ``P`` plus the jump
    covariance of an :class:`EpochRows` (as is otherwise), and its observations.

    Raises
    ------
    ModelError
        A jump covariance of another shape than ``P``.
    """
    if not isinstance(rows, EpochRows):
        return P, rows
    Q = rows.jump_covariance
    if Q is None:
        return P, rows.observations
    if Q.shape != P.shape:
        raise ModelError(f"jump_covariance has shape {Q.shape}, the state covariance "
                         f"{P.shape}")
    return P + Q, rows.observations
