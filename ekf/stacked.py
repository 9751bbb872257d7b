"""A bank's members propagated together over the same samples (one engine, K priors).

A multiple-hypothesis navigator steps K filters of one model over the same samples
between two discrete updates: only their priors and per-step parameters differ.
Driven one by one through `ekf.cd_filter.CdFilter` (``reset``, ``propagate``) each member
pays the driver's per-call Python (the chunk bookkeeping, a recorder, the epoch
search) and one compiled call. `propagate_members` does what those calls do for all
members in one pass: each member's prior checked and symmetrized as ``reset`` does
(`ekf.cd_filter.checked_prior`), its step data assembled as ``propagate`` does
(`ekf.cd_filter.step_data`), the steps of all members with as many samples run by ONE
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
    chunks = [series.shaped(model.n_u, model.n_p, model.n_c, model.n_w) for series in samples]
    out = [MemberState(x0, P0, None) for x0, P0 in starts]
    lengths: dict[int, list[int]] = {}
    for k, chunk in enumerate(chunks):
        if len(chunk) >= 2:
            lengths.setdefault(len(chunk), []).append(k)
    for members in lengths.values():
        x, P_packed, outputs = propagator.run_members(
            np.array([starts[k][0] for k in members]),
            pack_sym(np.array([starts[k][1] for k in members])),
            np.array([step_data(propagator, chunks[k]) for k in members]), keep)
        for j, k in enumerate(members):
            P = unpack_sym(P_packed[j])
            _check_covariance(P, f"at t={chunks[k].t[-1]:.6f} s")
            out[k] = MemberState(x[j].copy(), P, outputs[j])
    return out
