"""K members of a bank stepped by one compiled call: the step function written as C for
`LANES` lanes at once.

A bank's members (one filter per hypothesis, one model) step over the same samples, each
from its own prior with its own step data. `CompiledMembers` runs all ``K`` of them over
``N`` steps in ONE ctypes call: the step function is written out as C whose every
variable is a vector of `LANES` doubles (GCC's ``vector_size`` extension: AVX2 or SSE2
registers), one lane per member, so ``LANES`` members cost about what one costs
(measured on the constrained filter's 13-state step, 4 lanes: 1.4 µs per member and step
against 6.0 µs for CasADi's scalar code writing every output, under a load of 7).

**The same bits as the scalar code.** The C is written from the CasADi function's own
instruction list (`source`), instruction by instruction as CasADi's code generator
prints it (``ekf.compiled``): the four arithmetic operations, negation, ``x*x`` and
``2.*x`` elementwise on the vectors (IEEE operations, each lane rounded as a scalar
would be; no fused multiply-add: the flags of `ekf.compiled.CompileOptions`), and every
other operation (``sin``, ``sqrt``, comparisons, ...) lane by lane through the same C
library function; constants exact (hexadecimal literals). Each lane is therefore the
scalar step, to the bit (``tests/ekf/test_lanes.py`` against `ekf.compiled.CompiledLoop`).
A function with an operation outside `OPERATIONS` raises `LanesUnsupported`: the caller
steps its members one by one instead.

**Only the outputs asked for.** The state and covariance chain from step to step inside
the call; the final ones come back, and a per-step output is stored only when asked
for (a bank's members need the continuous-measurement innovations and their covariance;
the filtered states, the transitions and the predicted ones of every step, which a single
filter keeps for its outputs and the smoother, are not stored).
"""
from __future__ import annotations

import ctypes
import hashlib
from collections.abc import Sequence

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.compiled import CompileOptions, address, build_library
from ekf.errors import FilterError, ModelError

__all__ = ["LANES", "OPERATIONS", "CompiledMembers", "LanesUnsupported", "source"]

Array = npt.NDArray[np.float64]

#: Members per vector: 4 doubles (one AVX2 register, two SSE2 ones).
LANES = 4

#: Operations evaluated on whole vectors (IEEE, each lane as the scalar expression).
_VECTOR = {ca.OP_ASSIGN: "{0}", ca.OP_ADD: "({0}+{1})", ca.OP_SUB: "({0}-{1})",
           ca.OP_MUL: "({0}*{1})", ca.OP_DIV: "({0}/{1})", ca.OP_NEG: "(-{0})",
           ca.OP_SQ: "({0}*{0})", ca.OP_TWICE: "(2.*{0})", ca.OP_INV: "(1./{0})"}
#: Operations evaluated lane by lane: the scalar C of CasADi's code generator.
_LANEWISE = {
    ca.OP_SQRT: "sqrt({0})", ca.OP_SIN: "sin({0})", ca.OP_COS: "cos({0})",
    ca.OP_TAN: "tan({0})", ca.OP_ASIN: "asin({0})", ca.OP_ACOS: "acos({0})",
    ca.OP_ATAN: "atan({0})", ca.OP_EXP: "exp({0})", ca.OP_LOG: "log({0})",
    ca.OP_SINH: "sinh({0})", ca.OP_COSH: "cosh({0})", ca.OP_TANH: "tanh({0})",
    ca.OP_FLOOR: "floor({0})", ca.OP_CEIL: "ceil({0})", ca.OP_FABS: "fabs({0})",
    ca.OP_ERF: "erf({0})", ca.OP_SIGN: "({0}<0 ? -1 : {0}>0 ? 1 : {0})",
    ca.OP_NOT: "(!{0})", ca.OP_POW: "pow({0},{1})", ca.OP_CONSTPOW: "pow({0},{1})",
    ca.OP_ATAN2: "atan2({0},{1})", ca.OP_FMOD: "fmod({0},{1})",
    ca.OP_FMIN: "fmin({0},{1})", ca.OP_FMAX: "fmax({0},{1})",
    ca.OP_COPYSIGN: "copysign({0},{1})", ca.OP_HYPOT: "hypot({0},{1})",
    ca.OP_LT: "({0}<{1})", ca.OP_LE: "({0}<={1})", ca.OP_EQ: "({0}=={1})",
    ca.OP_NE: "({0}!={1})", ca.OP_AND: "({0}&&{1})", ca.OP_OR: "({0}||{1})",
    ca.OP_IF_ELSE_ZERO: "({0}?{1}:0)"}
#: Every operation `source` writes (besides inputs, outputs and constants).
OPERATIONS = frozenset(_VECTOR) | frozenset(_LANEWISE)

_HEAD = r"""#include <math.h>
typedef double vec_t __attribute__((vector_size({bytes})));
#define LANES {lanes}
"""

_LANE_FUNCTION = r"""static inline vec_t op{op}({params}) {{
  vec_t r; int l;
  for (l = 0; l < LANES; ++l) {{ {locals} r[l] = {expr}; }}
  return r;
}}
"""

_MEMBERS_LOOP = r"""
/* ---- ekf/lanes.py: K members over N steps, LANES at a time; member m's rows at
   x0 + m*NX, P0 + m*NP, d + m*N*ND; per-step output i of member m at
   steps[i] + (m*N + k)*size_i when steps[i] is not NULL ---- */
#define NX {nx}
#define NP {np}
#define ND {nd}
int {entry}(long long N, long long K, const double* x0, const double* P0,
            const double* d, double* x_end, double* P_end, double* const* steps) {{
  static const long long size_out[{n_out}] = {{{sizes_out}}};
  static const long long offset_out[{n_out}] = {{{offsets_out}}};
  vec_t xa[NX], Pa[NP], xb[NX], Pb[NP], dv[ND], other[{other}];
  vec_t* res[{n_out}];
  long long g, k, m[LANES];
  int i, j, l, live;
  for (g = 0; g < K; g += LANES) {{
    vec_t *x = xa, *P = Pa, *x_next = xb, *P_next = Pb, *swap;
    live = K - g < LANES ? (int)(K - g) : LANES;
    for (l = 0; l < LANES; ++l) m[l] = g + (l < live ? l : live - 1);
    for (j = 0; j < NX; ++j) for (l = 0; l < LANES; ++l) x[j][l] = x0[m[l] * NX + j];
    for (j = 0; j < NP; ++j) for (l = 0; l < LANES; ++l) P[j][l] = P0[m[l] * NP + j];
    for (k = 0; k < N; ++k) {{
      for (j = 0; j < ND; ++j)
        for (l = 0; l < LANES; ++l) dv[j][l] = d[(m[l] * N + k) * ND + j];
      res[0] = x_next;
      res[1] = P_next;
      for (i = 2; i < {n_out}; ++i) res[i] = steps[i] ? other + offset_out[i] : 0;
      {fname}(x, P, dv, {res_args});
      for (i = 0; i < {n_out}; ++i) {{
        if (!steps[i]) continue;
        for (l = 0; l < live; ++l)
          for (j = 0; j < size_out[i]; ++j)
            steps[i][(m[l] * N + k) * size_out[i] + j] = res[i][j][l];
      }}
      swap = x; x = x_next; x_next = swap;
      swap = P; P = P_next; P_next = swap;
    }}
    for (l = 0; l < live; ++l) {{
      for (j = 0; j < NX; ++j) x_end[m[l] * NX + j] = x[j][l];
      for (j = 0; j < NP; ++j) P_end[m[l] * NP + j] = P[j][l];
    }}
  }}
  return 0;
}}
"""


class LanesUnsupported(ModelError):
    """The function has an operation `source` does not write (`OPERATIONS`)."""


def _literal(value: float, lanes: int) -> str:
    """A constant as an exact C literal, splat over the lanes."""
    c = "NAN" if value != value else "INFINITY" if value == np.inf else \
        "(-INFINITY)" if value == -np.inf else float(value).hex()
    return "((vec_t){" + ", ".join([c] * lanes) + "})"


def _lane_function(op: int, expr: str) -> str:
    arity = 2 if "{1}" in expr else 1
    params = ", ".join(f"vec_t a{j}" for j in range(arity))
    locals_ = " ".join(f"double v{j} = a{j}[l];" for j in range(arity))
    return _LANE_FUNCTION.format(op=op, params=params, locals=locals_,
                                 expr=expr.format(*(f"v{j}" for j in range(arity))))


def source(fun: ca.Function, name: str, lanes: int = LANES) -> str:
    """C of ``static void name(const vec_t* a0, ..., vec_t* r0, ...)``: `fun` evaluated
    on `lanes` argument sets at once (module docstring); an output pointer that is NULL
    is not written.

    Parameters
    ----------
    fun : casadi.Function
        An SX function of dense vector inputs and outputs.
    name : str
        The C function's name.
    lanes : int

    Raises
    ------
    LanesUnsupported
        Not an SX function, or an operation outside `OPERATIONS`.
    """
    if not fun.is_a("SXFunction"):
        raise LanesUnsupported(f"{fun.name()} is not an SX function")
    body, used, work = [], {}, 0
    for k in range(fun.n_instructions()):
        op, i, o = fun.instruction_id(k), fun.instruction_input(k), fun.instruction_output(k)
        if op == ca.OP_INPUT:
            body.append(f"w{o[0]} = a{i[0]}[{i[1]}];")
        elif op == ca.OP_OUTPUT:
            body.append(f"if (r{o[0]}) r{o[0]}[{o[1]}] = w{i[0]};")
            continue
        elif op == ca.OP_CONST:
            body.append(f"w{o[0]} = {_literal(fun.instruction_constant(k), lanes)};")
        elif op in _VECTOR:
            body.append(f"w{o[0]} = " + _VECTOR[op].format(*(f"w{j}" for j in i)) + ";")
        elif op in _LANEWISE:
            used[op] = _LANEWISE[op]
            body.append(f"w{o[0]} = op{op}(" + ", ".join(f"w{j}" for j in i) + ");")
        else:
            raise LanesUnsupported(f"{fun.name()}: CasADi operation {op} is not written "
                                   f"for lanes")
        work = max(work, o[0] + 1)
    args = [f"const vec_t* restrict a{j}" for j in range(fun.n_in())] + \
           [f"vec_t* restrict r{j}" for j in range(fun.n_out())]
    lines = [_HEAD.format(bytes=8 * lanes, lanes=lanes)]
    lines += [_lane_function(op, expr) for op, expr in used.items()]
    lines.append(f"static void {name}({', '.join(args)}) {{")
    if work:
        lines.append("  vec_t " + ", ".join(f"w{j}" for j in range(work)) + ";")
    lines += ["  " + line for line in body] + ["}"]
    return "\n".join(lines) + "\n"


def _members_source(fun: ca.Function, entry: str, lanes: int) -> str:
    fname = f"{fun.name()}_lanes"
    sizes = [fun.nnz_out(i) for i in range(fun.n_out())]
    offsets = np.concatenate([[0, 0], np.cumsum([0] + sizes[2:])[:-1]]).astype(int)
    return source(fun, fname, lanes) + _MEMBERS_LOOP.format(
        nx=fun.nnz_in(0), np=fun.nnz_in(1), nd=fun.nnz_in(2), entry=entry, fname=fname,
        n_out=fun.n_out(), sizes_out=", ".join(map(str, sizes)),
        offsets_out=", ".join(map(str, offsets)), other=max(sum(sizes[2:]), 1),
        res_args=", ".join(f"res[{i}]" for i in range(fun.n_out())))


class CompiledMembers:
    """A step function ``(x, P, d) -> (x_next, P_next, ...)`` (`ekf.step.build_step`)
    compiled for K members stepped together (module docstring).

    Parameters
    ----------
    fun : casadi.Function
        SX; three dense vector inputs, outputs 0 and 1 the next ``x`` and ``P``.
    opts : ekf.compiled.CompileOptions

    Attributes
    ----------
    compile_seconds : float
        Wall time spent compiling in this process (0 when the library was cached).

    Raises
    ------
    LanesUnsupported
        A function `source` cannot write (checked before anything is compiled).
    """

    def __init__(self, fun: ca.Function, opts: CompileOptions = CompileOptions()) -> None:
        if fun.n_in() != 3 or fun.n_out() < 2:
            raise LanesUnsupported(f"{fun.name()}: not a step function (x, P, d) -> "
                                   f"(x_next, P_next, ...)")
        unknown = {fun.instruction_id(k) for k in range(fun.n_instructions())} - \
            OPERATIONS - {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST}
        if unknown or not fun.is_a("SXFunction"):
            raise LanesUnsupported(f"{fun.name()}: operations {sorted(unknown)} are not "
                                   f"written for lanes")
        self.sizes_in = tuple(fun.nnz_in(i) for i in range(3))
        self.sizes_out = tuple(fun.nnz_out(i) for i in range(fun.n_out()))
        entry = f"{fun.name()}_members"
        version = hashlib.sha256(repr(sorted(_LANEWISE.items())).encode()
                                 + repr(sorted(_VECTOR.items())).encode()).hexdigest()
        self._lib, self._fun, self.compile_seconds = build_library(
            fun, (_HEAD, _LANE_FUNCTION, _MEMBERS_LOOP, version, str(LANES)), entry,
            lambda: _members_source(fun, entry, LANES), opts)
        self._fun.argtypes = [ctypes.c_longlong] * 2 + [ctypes.c_void_p] * 6

    def run(self, x0: Array, P0: Array, d: Array, keep: Sequence[int] = ()
            ) -> tuple[Array, Array, list]:
        """Run every member ``N`` steps.

        Parameters
        ----------
        x0 : ndarray, shape (K, n)
        P0 : ndarray, shape (K, n(n+1)/2)
            Packed covariances.
        d : ndarray, shape (K, N, k_d)
            Each member's step data rows.
        keep : sequence of int
            The outputs stored at every step (indices of the function's outputs).

        Returns
        -------
        x : ndarray, shape (K, n)
            Each member's state after its ``N`` steps.
        P : ndarray, shape (K, n(n+1)/2)
        steps : list
            Per output of the function, ``(K, N, size)`` when kept, else None.
        """
        x0 = np.ascontiguousarray(x0, dtype=float)
        P0 = np.ascontiguousarray(P0, dtype=float)
        d = np.ascontiguousarray(d, dtype=float)
        K = x0.shape[0]
        nx, n_p, nd = self.sizes_in
        if x0.shape != (K, nx) or P0.shape != (K, n_p) or d.ndim != 3 or d.shape[0] != K \
                or d.shape[2] != nd:
            raise FilterError(f"compiled members expect x (K, {nx}), P (K, {n_p}), d (K, N, "
                              f"{nd}); got {x0.shape}, {P0.shape}, {d.shape}")
        N = d.shape[1]
        steps = [np.empty((K, N, size)) if i in keep else None
                 for i, size in enumerate(self.sizes_out)]
        pointers = (ctypes.c_void_p * len(steps))(
            *[None if s is None else address(s) for s in steps])
        x, P = np.empty((K, nx)), np.empty((K, n_p))
        if K and N:
            self._fun(N, K, address(x0), address(P0), address(d), address(x), address(P),
                      ctypes.addressof(pointers))
        else:
            x[...], P[...] = x0, P0
        return x, P, steps
