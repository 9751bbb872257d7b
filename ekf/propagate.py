"""Run the per-step function over many steps: compiled C loop or CasADi ``mapaccum``.

:class:`Propagator` is what the filter driver calls between discrete updates. Backends:

``"compiled"`` (default when a C compiler is found)
    :class:`ekf.compiled.CompiledLoop`: generated C, one ctypes call per span.
``"casadi"``
    The CasADi virtual machine: ``mapaccum`` over power-of-two blocks (a span of ``N``
    steps is ``popcount(N)`` calls; blocks are built lazily and kept).
``"casadi-jit"``
    The same blocks JIT-compiled by CasADi (``jit=True, compiler="shell"``): one
    compilation per block size and process. Kept for comparison in the benchmark.

All backends return the same :class:`StepOutputs`. :meth:`Propagator.run_members` runs
a bank's K members over the same number of steps: with the compiled backend in one call
(`ekf.lanes.CompiledMembers`, built on first use: the same bits as `run` member by
member; a single member goes through `run`, as 4 lanes would cost it about twice the
scalar step), storing only the per-step outputs asked for.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Literal

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.compiled import CompiledLoop, CompileOptions, compiler_available
from ekf.errors import FilterError
from ekf.lanes import CompiledMembers, LanesUnsupported
from ekf.model import CdModel
from ekf.packing import to_casadi, to_numpy
from ekf.step import STEP_OUTPUTS, StepData, StepOptions, build_step

__all__ = ["Backend", "StepOutputs", "Propagator"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Backend = Literal["auto", "compiled", "casadi", "casadi-jit"]

#: Largest mapaccum block of the CasADi backends (longer spans are several calls).
MAX_BLOCK_LOG2 = 10


@dataclass(frozen=True)
class StepOutputs:
    """Per-step outputs of ``N`` steps (see :mod:`ekf.step`); from
    :meth:`Propagator.run_members`, the outputs not kept are None.

    Attributes
    ----------
    x_next : ndarray, shape (N, n)
        Predicted state at ``t_{k+1}``.
    P_next : ndarray, shape (N, n(n+1)/2)
        Its covariance, packed.
    x_filt : ndarray, shape (N, n)
        State at ``t_k`` after the continuous-measurement update.
    P_filt : ndarray, shape (N, n(n+1)/2)
    innov : ndarray, shape (N, n_c)
        Continuous-measurement innovation ``z_c − h_c``.
    S : ndarray, shape (N, n_c(n_c+1)/2)
        Its covariance, packed.
    nis : ndarray, shape (N,)
        ``νᵀ S⁻¹ ν`` (empty when the model has no continuous measurement).
    Phi : ndarray, shape (N, n*n)
        Transition ``Φ̃`` of each step, row by row.
    """

    x_next: Array | None
    P_next: Array | None
    x_filt: Array | None
    P_filt: Array | None
    innov: Array | None
    S: Array | None
    nis: Array | None
    Phi: Array | None

    @property
    def steps(self) -> int:
        """Number of steps ``N``."""
        return next(a for a in (getattr(self, f) for f in STEP_OUTPUTS)
                    if a is not None).shape[0]


def _outputs(arrays: list[Array | None], n_c: int) -> StepOutputs:
    fields = dict(zip(STEP_OUTPUTS, arrays))
    nis = fields["nis"]
    if nis is not None:
        fields["nis"] = nis.reshape(-1) if n_c else np.zeros(nis.shape[0])[:0]
    return StepOutputs(**fields)


class Propagator:
    """Runs a model's step function over spans of steps.

    Parameters
    ----------
    model : CdModel
    step_options : StepOptions
    backend : {"auto", "compiled", "casadi", "casadi-jit"}
        ``"auto"``: compiled when the compiler is available, else ``"casadi"``.
    compile_options : CompileOptions

    Attributes
    ----------
    step : casadi.Function
        The per-step SX function.
    data : StepData
        Layout of a step's data row.
    backend : str
        The backend in use.
    build_seconds : float
        Time to build (and compile, if not cached) in this process.
    """

    def __init__(self, model: CdModel, step_options: StepOptions = StepOptions(), *,
                 backend: Backend = "auto",
                 compile_options: CompileOptions = CompileOptions()) -> None:
        start = time.perf_counter()
        self.model = model
        self.data = StepData.of(model, step_options)
        self.step = build_step(model, step_options)
        if backend == "auto":
            backend = "compiled" if compiler_available(compile_options) else "casadi"
            if backend == "casadi":
                log.warning("no C compiler %r: using the slower CasADi VM backend",
                            compile_options.compiler)
        if backend not in ("compiled", "casadi", "casadi-jit"):
            raise FilterError(f"unknown backend {backend!r}")
        self.backend = backend
        self._loop = CompiledLoop(self.step, compile_options) if backend == "compiled" else None
        self._compile_options = compile_options
        self._members: CompiledMembers | None = None
        self._members_unsupported = backend != "compiled"
        self._blocks: dict[int, ca.Function] = {}
        self.build_seconds = time.perf_counter() - start

    def run(self, x0: npt.ArrayLike, P0_packed: npt.ArrayLike, d: Array) -> StepOutputs:
        """Run ``N`` steps from a prior.

        Parameters
        ----------
        x0 : array_like, shape (n,)
            Prior state at the first step's start.
        P0_packed : array_like, shape (n(n+1)/2,)
        d : ndarray, shape (N, k_d)
            Step data rows (:meth:`ekf.step.StepData.assemble`).

        Returns
        -------
        StepOutputs
        """
        d = np.asarray(d, dtype=float)
        if d.ndim != 2 or d.shape[1] != self.data.size:
            raise FilterError(f"step data must have shape (N, {self.data.size}), got {d.shape}")
        if self._loop is not None:
            return _outputs(self._loop.run(np.asarray(x0), np.asarray(P0_packed), d),
                            self.model.n_c)
        return self._run_blocks(np.asarray(x0, dtype=float),
                                np.asarray(P0_packed, dtype=float), d)

    def run_members(self, x0: Array, P0_packed: Array, d: Array,
                    keep: tuple[str, ...] = STEP_OUTPUTS) -> tuple[Array, Array, list]:
        """Run K members ``N`` steps each, from their priors (module docstring).

        Parameters
        ----------
        x0 : ndarray, shape (K, n)
        P0_packed : ndarray, shape (K, n(n+1)/2)
        d : ndarray, shape (K, N, k_d)
            Each member's step data rows (``N >= 1``).
        keep : tuple of str
            The per-step outputs kept (names of `ekf.step.STEP_OUTPUTS`).

        Returns
        -------
        x : ndarray, shape (K, n)
            Each member's state after the ``N`` steps.
        P_packed : ndarray, shape (K, n(n+1)/2)
        outputs : list of StepOutputs
            Each member's, the outputs not in `keep` None.
        """
        d = np.asarray(d, dtype=float)
        if d.ndim != 3 or d.shape[2] != self.data.size or d.shape[1] < 1:
            raise FilterError(f"member step data must have shape (K, N >= 1, "
                              f"{self.data.size}), got {d.shape}")
        indices = [STEP_OUTPUTS.index(name) for name in keep]
        # one member alone: the scalar loop (the lanes would step 3 idle copies of it)
        members = self._compiled_members() if d.shape[0] > 1 else None
        if members is None:
            runs = [self.run(x, P, rows) for x, P, rows in zip(x0, P0_packed, d)]
            arrays = [[getattr(r, name) for r in runs] for name in STEP_OUTPUTS]
            x = np.array([r.x_next[-1] for r in runs]).reshape(len(runs), -1)
            P = np.array([r.P_next[-1] for r in runs]).reshape(len(runs), -1)
        else:
            x, P, steps = members.run(x0, P0_packed, d, indices)
            arrays = [None if s is None else list(s) for s in steps]
        kept = [a if i in indices else None for i, a in enumerate(arrays)]
        return x, P, [_outputs([None if a is None else a[k] for a in kept], self.model.n_c)
                      for k in range(d.shape[0])]

    def _compiled_members(self) -> CompiledMembers | None:
        """The members' compiled loop (built on first use); None when the backend is not
        the compiled one or the step cannot be written for lanes."""
        if self._members is None and not self._members_unsupported:
            try:
                self._members = CompiledMembers(self.step, self._compile_options)
            except LanesUnsupported as exc:
                log.info("members stepped one by one: %s", exc)
                self._members_unsupported = True
        return self._members

    def _block(self, size: int) -> ca.Function:
        if size not in self._blocks:
            opts: dict = {}
            if self.backend == "casadi-jit":
                opts = {"jit": True, "compiler": "shell",
                        "jit_options": {"flags": ["-O2"], "verbose": False}}
            self._blocks[size] = self.step.mapaccum(f"{self.step.name()}_acc{size}", size,
                                                    [0, 1], [0, 1], opts)
        return self._blocks[size]

    def _run_blocks(self, x: Array, P: Array, d: Array) -> StepOutputs:
        chunks: list[list[Array]] = []
        start, remaining = 0, d.shape[0]
        while remaining:
            size = 1 << min(remaining.bit_length() - 1, MAX_BLOCK_LOG2)
            res = self._block(size)(to_casadi(x), to_casadi(P),
                                    to_casadi(d[start:start + size]))
            arrays = [to_numpy(r, columns=False).T.reshape(size, -1) for r in res]
            chunks.append(arrays)
            x, P = arrays[0][-1], arrays[1][-1]
            start += size
            remaining -= size
        if not chunks:
            empty = [np.zeros((0, self.step.nnz_out(i))) for i in range(self.step.n_out())]
            return _outputs(empty, self.model.n_c)
        return _outputs([np.concatenate(c, axis=0) for c in zip(*chunks)], self.model.n_c)
