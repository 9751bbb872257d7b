"""A bank's members propagated together over the same samples (one engine, K priors).

A multiple-hypothesis navigator steps K filters of one model over the same samples
between two discrete updates: only their priors and per-step parameters differ.
Driven one by one through `ekf.cd_filter.CdFilter` (``reset``, ``propagate``) each member
pays the driver's per-call Python (the chunk bookkeeping, a recorder, the epoch
search) and one compiled call. `propagate_members` does what those calls do for all
members in one pass: each member's prior checked and symmetrized as ``reset`` does
(`ekf.cd_filter.checked_prior`), its step data assembled as ``propagate`` does
(`ekf.cd_filter.step_data`; for members over the same sample times, checked and assembled
for all at once), the steps of all members with as many samples run by ONE
call of the engine's propagator (`ekf.propagate.Propagator.run_members`: the step
function written for lanes, one member per lane, `ekf.lanes`), the posteriors unpacked
and checked. Only the per-step outputs asked for are kept (``keep``).

Equal to ``reset`` + ``propagate`` of each member in turn, to the bit
(``tests/ekf/test_stacked.py``).

`update_members` is the discrete update of the members at an epoch, as the engine's
``update`` makes it (`ekf.update.discrete_update` with its gate and mode) for each: the
members whose rows were evaluated at their prior (`ekf.update.EvaluatedObservations`,
diagonal ``R``), as many rows each, every row passing the gate, updated with the Kalman
arithmetic of `ekf.update.kalman_update` stacked (NumPy's stacked ``matmul`` makes each
member's BLAS call as for that member alone, on arrays of the same layout; the Cholesky
factor and solve are each member's own LAPACK calls), the others one by one. Only the
posteriors come back (no `ekf.update.UpdateRecord`). Equal to ``update`` of each member,
to the bit (``tests/ekf/test_stacked_update.py``).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.cd_filter import CdFilter, _check_covariance, checked_prior, step_data
from ekf.errors import FilterDivergedError, ModelError
from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import StepOutputs
from ekf.series import InputSeries, prior_and_rows
from ekf.step import STEP_OUTPUTS
from ekf.update import EvaluatedObservations, _cho_factor, _cho_solve, discrete_update

__all__ = ["MemberState", "propagate_members", "update_members"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class MemberState:
    """One member after `propagate_members`.

    Attributes
    ----------
    x : ndarray, shape (n,)
        State at the last sample.
    P : ndarray, shape (n, n)
        Its covariance (symmetric).
    outputs : StepOutputs or None
        The per-step outputs (None: a single sample, no step).
    """

    x: Array
    P: Array
    outputs: StepOutputs | None


def propagate_members(engine: CdFilter, priors: Sequence[tuple[Array, Array]],
                      samples: Sequence[InputSeries], *,
                      keep: tuple[str, ...] = STEP_OUTPUTS) -> list[MemberState]:
    """Propagate each member from its prior through its samples (module docstring).

    Parameters
    ----------
    engine : CdFilter
        The members' engine (its model and propagator; its own state is left alone).
    priors : sequence of (x (n,), P (n, n))
        Each member's prior at its first sample.
    samples : sequence of InputSeries
        Each member's samples (``M >= 1``; ``M − 1`` steps), one per prior.
    keep : tuple of str
        The per-step outputs kept (names of `ekf.step.STEP_OUTPUTS`; the others are None
        in each member's `StepOutputs`).

    Returns
    -------
    list of MemberState
        In the order of `priors`.

    Raises
    ------
    ModelError
        Wrong shapes, or as many priors as sample series not given.
    ekf.errors.FilterDivergedError
        A prior or posterior covariance that is not positive definite.
    """
    if len(priors) != len(samples):
        raise ModelError(f"{len(priors)} priors for {len(samples)} sample series")
    model, propagator = engine.model, engine.propagator
    X0, P0 = _checked_priors(model.n, priors)
    out = [MemberState(x0, p0, None) for x0, p0 in zip(X0, P0)]
    lengths: dict[int, list[int]] = {}
    for k, series in enumerate(samples):
        if len(series) < 2:                 # checked all the same
            series.shaped(model.n_u, model.n_p, model.n_c, model.n_w)
        else:
            lengths.setdefault(len(series), []).append(k)
    for members in lengths.values():
        group = [samples[k] for k in members]
        d = _step_data_together(propagator, group)
        if d is None:
            d = np.array([step_data(propagator, series.shaped(
                model.n_u, model.n_p, model.n_c, model.n_w)) for series in group])
        x, P_packed, outputs = propagator.run_members(
            X0[members], pack_sym(P0[members]), d, keep)
        P_all = unpack_sym(P_packed)
        for j, k in enumerate(members):
            _check_covariance(P_all[j], lambda k=k: f"at t="       # formatted if it fails
                              f"{float(np.asarray(samples[k].t)[-1]):.6f} s")
            out[k] = MemberState(x[j].copy(), P_all[j], outputs[j])
    return out


def _checked_priors(n: int, priors: Sequence[tuple[Array, Array]]) -> tuple[Array, Array]:
    """`checked_prior` of every member, stacked: states (K, n) and symmetrized
    covariances (K, n, n), the same numbers (the symmetrization elementwise) and the
    same errors (a prior of another shape, or none: each member's own check)."""
    try:
        X = np.array([x for x, _ in priors], dtype=float)
        P = np.array([P for _, P in priors], dtype=float)
    except ValueError:                      # shapes that do not stack
        X = P = None
    if X is None or X.shape != (len(priors), n) or P.shape != (len(priors), n, n):
        starts = [checked_prior(n, x, P) for x, P in priors]
        return np.array([x for x, _ in starts]).reshape(-1, n), \
            np.array([P for _, P in starts]).reshape(-1, n, n)
    for P_k in P:
        _check_covariance(P_k, "in the initial covariance")
    return X, 0.5 * (P + P.transpose(0, 2, 1))


def _step_data_together(propagator, samples: Sequence[InputSeries]) -> Array | None:
    """The step data ``(K, N, k_d)`` of members over the same sample times, their fields
    checked together as `ekf.series.InputSeries.shaped` checks each member's (and
    assembled as `ekf.cd_filter.step_data` assembles them); None when the members' times
    or field shapes differ, one has ``u_lin`` and another not, or a check fails:
    `shaped` member by member then says what is wrong."""
    data = propagator.data
    t = np.asarray(samples[0].t, dtype=float)
    if t.ndim != 1 or any(s.t is not samples[0].t and not np.array_equal(s.t, t)
                          for s in samples[1:]):
        return None
    M = t.size
    sizes = {"u": data.n_u, "p": data.n_p, "z_c": data.n_c, "q_c": data.n_w, "r_c": data.n_c}
    with_lin = [s.u_lin is not None for s in samples]
    if any(with_lin) and not all(with_lin):
        return None
    if all(with_lin):
        sizes["u_lin"] = data.n_u
    fields = {}
    try:
        for name, k in sizes.items():
            fields[name] = _field_together([getattr(s, name) for s in samples], M, k)
            if fields[name] is None:
                return None
    except (TypeError, ValueError):         # not numbers
        return None
    dt = np.diff(t)
    if not (np.isfinite(t).all() and (dt > 0.0).all()
            and all(np.isfinite(a).all() for a in fields.values())
            and (fields["q_c"] >= 0.0).all() and (fields["r_c"] >= 0.0).all()):
        return None
    if data.n_lin and "u_lin" not in fields:
        return None                         # each member's own window (`step_data`)
    return data.assemble(fields["u"], fields["p"][:, :-1], fields["z_c"][:, :-1],
                         np.broadcast_to(dt, (len(samples), M - 1)), fields["q_c"][:, :-1],
                         fields["r_c"][:, :-1], u_lin=fields.get("u_lin"))


def _field_together(rows: list, M: int, k: int) -> Array | None:
    """One field of the members' samples, shape ``(K, M, k)`` (a row ``(k,)`` held over
    the samples; None: zeros, all None: one array of zeros), or None when a member's has
    another shape. Views where the values repeat (`assemble` copies them): one member's
    with the member axis, the members' one row each broadcast over the samples, one
    array all members share (the raw inputs, the linearization input) broadcast over the
    members; else the members' arrays copied together (np.array of equal shapes:
    np.stack's copy, without its generic argument handling)."""
    K = len(rows)
    if all(a is None for a in rows):
        return np.zeros((K, M, k))
    if rows[0] is not None and all(a is rows[0] for a in rows):
        one = np.asarray(rows[0], dtype=float)
        if one.shape not in ((M, k), (k,)):
            return None
        return np.broadcast_to(one if one.ndim == 2 else one[None], (K, M, k))
    arrays = [np.zeros((M, k)) if a is None else np.asarray(a, dtype=float) for a in rows]
    if any(a.shape not in ((M, k), (k,)) for a in arrays):
        return None
    if all(a.ndim == 1 for a in arrays):
        return np.broadcast_to(np.array(arrays)[:, None, :], (K, M, k))
    full = [a if a.ndim == 2 else np.broadcast_to(a, (M, k)) for a in arrays]
    return full[0][None] if K == 1 else np.array(full)


def update_members(engine: CdFilter, priors: Sequence[tuple[Array, Array]], rows: Sequence
                   ) -> list[tuple[Array, Array]]:
    """The discrete update of each member from its prior with its rows (module docstring).

    Parameters
    ----------
    engine : CdFilter
        The members' engine (its gate and update mode; its own state is left alone).
    priors : sequence of (x (n,), P (n, n))
        Each member's prior.
    rows : sequence
        Each member's rows: a list of `ekf.update.Observation` or an
        `ekf.series.EpochRows` (its jump covariance added to the prior first, as the
        engine's epoch update adds it).

    Returns
    -------
    list of (x (n,), P (n, n))
        Each member's posterior, in order.

    Raises
    ------
    ekf.errors.FilterDivergedError
        An innovation covariance that is not positive definite.
    """
    gate, sequential = engine.config.gate, engine.config.sequential
    out: list = [None] * len(priors)
    together: dict[int, list[tuple[int, Array, Array, EvaluatedObservations]]] = {}
    for k, ((x, P), one) in enumerate(zip(priors, rows)):
        P, one = prior_and_rows(P, one)
        if not sequential and isinstance(one, EvaluatedObservations) and one.innov.size \
                and one.R.ndim == 1 and one.evaluated_at(x):
            together.setdefault(one.innov.size, []).append((k, x, P, one))
        else:
            out[k] = discrete_update(x, P, one, gate=gate, sequential=sequential)[:2]
    for members in together.values():
        for k, x, P in _stacked_kalman(members, gate):
            out[k] = (x, P)
    return out


def _stacked_kalman(members: list, gate) -> list[tuple[int, Array, Array]]:
    """`ekf.update.kalman_update`'s posterior of members ``(k, x, P, rows)`` with as many
    rows each, stacked where every row passes the gate (a member with a rejected row:
    its own `kalman_update`)."""
    # the members' arrays stacked (np.array of equal shapes: np.stack's copy, without
    # its generic argument handling)
    x = np.array([one[1] for one in members])
    P = np.array([one[2] for one in members])
    H = np.array([one[3].H for one in members])
    innov = np.array([one[3].innov for one in members])
    R = np.array([one[3].R for one in members])
    m = innov.shape[1]
    R_mat = np.zeros(R.shape + (m,))                  # np.diag(R) of each: every
    R_mat.reshape(R.shape[0], m * m)[:, ::m + 1] = R  # (m+1)-th element
    PHt = P @ H.transpose(0, 2, 1)                    # (np.swapaxes, without its wrapper)
    S = H @ PHt + R_mat
    passed = [True] * len(members)
    if gate is not None:
        passed = _gate_passes(gate, members, innov, S)
    gains, kept, out = [], [], []
    for j, (k, x_j, P_j, rows) in enumerate(members):
        if not passed[j]:
            out.append((k, *discrete_update(x_j, P_j, rows, gate=gate)[:2]))
            continue
        try:
            factor = _cho_factor(S[j])
        except np.linalg.LinAlgError as exc:
            raise FilterDivergedError(f"innovation covariance is not positive definite: "
                                      f"{exc}") from exc
        gains.append(_cho_solve(factor, PHt[j].T).T)
        kept.append(j)
    if not kept:
        return out
    K = np.array(gains)
    if len(kept) < len(members):
        x, P, H, innov, R = x[kept], P[kept], H[kept], innov[kept], R[kept]
    x_post = x + (K @ innov[..., None])[..., 0]
    A = np.eye(P.shape[-1]) - K @ H
    P_post = A @ P @ A.transpose(0, 2, 1) + (K * R[:, None, :]) @ K.transpose(0, 2, 1)
    P_post = 0.5 * (P_post + P_post.transpose(0, 2, 1))
    return out + [(members[j][0], x_post[i], P_post[i]) for i, j in enumerate(kept)]


def _gate_passes(gate, members: list, innov: Array, S: Array) -> list[bool]:
    """Whether every row of each member passes the engine's gate (`ekf.gating.Gate.
    accepted_rows` of its rows): the members' scalar rows (ids ``0 .. m−1``, as the fault
    screen numbers them) tested together, the others member by member."""
    groups = [one[3].groups for one in members]
    if gate.scope == "rows" and all(g.shape == innov.shape[1:] for g in groups) \
            and np.count_nonzero(np.array(groups) != np.arange(innov.shape[1])) == 0:
        return gate.scalar_rows_accepted(innov, S).all(axis=1).tolist()
    return [bool(gate.accepted_rows(innov[j], S[j], one[3].groups).all())
            for j, one in enumerate(members)]
