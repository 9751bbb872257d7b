"""A bank's members propagated together over the same samples (one engine, K priors).

A multiple-hypothesis navigator steps K filters of one model over the same samples
between two discrete updates: only their priors and per-step parameters differ.
Driven one by one through `ekf.cd_filter.CdFilter` (``reset``, ``propagate``) each member
pays the driver's per-call Python (the chunk bookkeeping, a recorder, the epoch
search). `propagate_members` does what those calls do for all members in one pass:
each member's prior checked and symmetrized as ``reset`` does
(`ekf.cd_filter.checked_prior`), its step data assembled as ``propagate`` does
(`ekf.cd_filter.step_data`), its steps run by the engine's propagator (one compiled call
per member: the same C function, so the same bits as ``CdFilter.propagate``), its
posterior unpacked and checked.

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
                      samples: Sequence[InputSeries]) -> list[MemberState]:
    """Propagate each member from its prior through its samples (module docstring).

    Parameters
    ----------
    engine : CdFilter
        The members' engine (its model and propagator; its own state is left alone).
    priors : sequence of (x (n,), P (n, n))
        Each member's prior at its first sample.
    samples : sequence of InputSeries
        Each member's samples (``M >= 1``; ``M − 1`` steps), one per prior.

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
    out = []
    for (x_prior, P_prior), series in zip(priors, samples):
        x0, P0 = checked_prior(model.n, x_prior, P_prior)
        chunk = series.shaped(model.n_u, model.n_p, model.n_c, model.n_w)
        if len(chunk) < 2:
            out.append(MemberState(x0, P0, None))
            continue
        steps = propagator.run(x0, pack_sym(P0), step_data(propagator, chunk))
        P = unpack_sym(steps.P_next[-1])
        _check_covariance(P, f"at t={chunk.t[-1]:.6f} s")
        out.append(MemberState(steps.x_next[-1].copy(), P, steps))
    return out
