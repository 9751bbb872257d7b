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
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.cd_filter import CdFilter, _check_covariance, checked_prior, step_data
from ekf.errors import ModelError
from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import StepOutputs
from ekf.series import InputSeries
from ekf.step import STEP_OUTPUTS

__all__ = ["MemberState", "propagate_members"]

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
    starts = [checked_prior(model.n, x_prior, P_prior) for x_prior, P_prior in priors]
    out = [MemberState(x0, P0, None) for x0, P0 in starts]
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
            np.array([starts[k][0] for k in members]),
            pack_sym(np.array([starts[k][1] for k in members])), d, keep)
        P_all = unpack_sym(P_packed)
        for j, k in enumerate(members):
            _check_covariance(P_all[j], f"at t={float(np.asarray(samples[k].t)[-1]):.6f} s")
            out[k] = MemberState(x[j].copy(), P_all[j], outputs[j])
    return out


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
            rows = [getattr(s, name) for s in samples]
            arrays = [np.zeros((M, k)) if a is None else np.asarray(a, dtype=float)
                      for a in rows]
            if any(a.shape not in ((M, k), (k,)) for a in arrays):
                return None
            fields[name] = np.stack([a if a.ndim == 2 else np.broadcast_to(a, (M, k))
                                     for a in arrays])
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
