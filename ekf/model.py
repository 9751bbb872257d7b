"""Model descriptions: the continuous–discrete process model and discrete measurement models.

A :class:`CdModel` describes, with CasADi functions of ``(x, u, p)``,

* the dynamics ``ẋ = f(x, u, p) + G(x, u, p) w``, with ``w`` white noise of spectral
  density ``Qc = diag(q_c)`` (unit: [w]²·s);
* an optional *continuous* measurement sampled at every step,
  ``z_c = h_c(x, u, p) + D(x, u, p) w + v_c``, whose noise ``D w`` is the SAME ``w`` as
  the process noise (correlated noise, paper 2017 eq. 14) plus an optional independent
  white ``v_c`` of spectral density ``Rc = diag(r_c)``.

``x`` is the state (layout :class:`~ekf.layout.StateLayout`), ``u`` an input sample
(e.g. IMU ``[f_b; omega_ib_b]``), ``p`` a per-step parameter vector; ``u`` and ``p``
may be empty. When the noise is the error of a measured input (``u_meas = u_true + w``),
linearizing ``f(x, u_meas − w)`` gives ``G = −∂f/∂u`` and ``D = −∂h_c/∂u``: these are the
defaults.

A :class:`MeasurementModel` describes one *row type* of a discrete measurement,
``z_i = h(x, p_i) + v_i`` (``k`` components per row, e.g. one pseudorange per satellite
with ``p_i`` the satellite's position and clock). An update stacks ``m`` rows, ``m``
free to change from epoch to epoch. Jacobians come from ``casadi.jacobian`` once, here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.compiled import CompiledRows, compiler_available
from ekf.errors import ModelError
from ekf.layout import StateLayout
from ekf.packing import to_casadi, to_numpy

__all__ = ["CdModel", "MeasurementModel"]

Array = npt.NDArray[np.float64]


def _as_sx_function(fun: ca.Function, name: str) -> ca.Function:
    if not isinstance(fun, ca.Function):
        raise ModelError(f"{name} must be a casadi.Function, got {type(fun).__name__}")
    if fun.is_a("SXFunction"):
        return fun
    try:
        return fun.expand()
    except RuntimeError as exc:  # MX with non-expandable nodes (e.g. an interpolant)
        raise ModelError(f"{name} cannot be expanded to SX: {exc}") from exc


def _check_signature(fun: ca.Function, name: str, sizes: tuple[int, ...]) -> None:
    if fun.n_in() != len(sizes):
        raise ModelError(f"{name} must take {len(sizes)} inputs, it takes {fun.n_in()}")
    for i, size in enumerate(sizes):
        if fun.size_in(i) != (size, 1) and not (size == 0 and fun.numel_in(i) == 0):
            raise ModelError(f"{name} input {fun.name_in(i)!r} has shape {fun.size_in(i)}, "
                             f"expected ({size}, 1)")


@dataclass(frozen=True, eq=False)
class CdModel:
    """A continuous-time process model with an optional correlated continuous measurement.

    Use :meth:`from_expressions` or :meth:`from_functions`.

    Attributes
    ----------
    layout : StateLayout
        Names of the ``n`` state components.
    f : casadi.Function
        ``(x[n], u[n_u], p[n_p]) -> xdot[n]``, state derivative (state units per second).
    G : casadi.Function
        ``(x, u, p) -> (n, n_w)`` noise input map.
    h_c : casadi.Function or None
        ``(x, u, p) -> (n_c,)`` continuous measurement, sampled at every step.
    D : casadi.Function or None
        ``(x, u, p) -> (n_c, n_w)`` map of the shared noise ``w`` into ``h_c``.
    name : str
        Used to name generated code (and its cache files).
    """

    layout: StateLayout
    f: ca.Function
    G: ca.Function
    h_c: ca.Function | None = None
    D: ca.Function | None = None
    name: str = "model"
    n_u: int = field(init=False)
    n_p: int = field(init=False)
    n_w: int = field(init=False)
    n_c: int = field(init=False)

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ModelError(f"model name {self.name!r} must be an identifier")
        n = self.layout.size
        f = _as_sx_function(self.f, "f")
        n_u, n_p = f.numel_in(1), f.numel_in(2)
        _check_signature(f, "f", (n, n_u, n_p))
        if f.size_out(0) != (n, 1):
            raise ModelError(f"f returns {f.size_out(0)}, expected ({n}, 1)")
        G = _as_sx_function(self.G, "G")
        _check_signature(G, "G", (n, n_u, n_p))
        n_w = G.size2_out(0)
        if G.size1_out(0) != n:
            raise ModelError(f"G returns {G.size_out(0)}, expected ({n}, n_w)")
        n_c = 0
        if (self.h_c is None) != (self.D is None):
            raise ModelError("h_c and D must be given together")
        if self.h_c is not None:
            h_c = _as_sx_function(self.h_c, "h_c")
            D = _as_sx_function(self.D, "D")
            _check_signature(h_c, "h_c", (n, n_u, n_p))
            _check_signature(D, "D", (n, n_u, n_p))
            n_c = h_c.numel_out(0)
            if D.size_out(0) != (n_c, n_w):
                raise ModelError(f"D returns {D.size_out(0)}, expected ({n_c}, {n_w})")
            object.__setattr__(self, "h_c", h_c)
            object.__setattr__(self, "D", D)
        for attr, value in (("f", f), ("G", G), ("n_u", n_u), ("n_p", n_p),
                            ("n_w", n_w), ("n_c", n_c)):
            object.__setattr__(self, attr, value)

    @property
    def n(self) -> int:
        """State dimension."""
        return self.layout.size

    @classmethod
    def from_expressions(cls, layout: StateLayout, x: ca.SX, u: ca.SX, p: ca.SX,
                         xdot: ca.SX, *, h_c: ca.SX | None = None, G: ca.SX | None = None,
                         D: ca.SX | None = None, name: str = "model") -> "CdModel":
        """Build a model from SX expressions of the symbols ``x, u, p``.

        Parameters
        ----------
        layout : StateLayout
        x, u, p : casadi.SX, shapes (n, 1), (n_u, 1), (n_p, 1)
            Symbols (``u`` and ``p`` may be ``SX(0, 1)``).
        xdot : casadi.SX, shape (n, 1)
        h_c : casadi.SX, shape (n_c, 1), optional
            Continuous measurement; its value ``z_c`` is given per step at run time.
        G : casadi.SX, shape (n, n_w), optional
            Noise input map; default ``−∂xdot/∂u`` (noise = input measurement error).
        D : casadi.SX, shape (n_c, n_w), optional
            Default ``−∂h_c/∂u``.
        name : str
        """
        args = [x, u, p]
        if G is None:
            G = -ca.jacobian(xdot, u)
        fun_h = fun_D = None
        if h_c is not None:
            if D is None:
                D = -ca.jacobian(h_c, u)
            fun_h = ca.Function("h_c", args, [h_c], ["x", "u", "p"], ["z_c"])
            fun_D = ca.Function("D", args, [ca.densify(D)], ["x", "u", "p"], ["D"])
        elif D is not None:
            raise ModelError("D given without h_c")
        return cls(layout=layout,
                   f=ca.Function("f", args, [xdot], ["x", "u", "p"], ["xdot"]),
                   G=ca.Function("G", args, [ca.densify(G)], ["x", "u", "p"], ["G"]),
                   h_c=fun_h, D=fun_D, name=name)

    @classmethod
    def from_functions(cls, layout: StateLayout, f: ca.Function, *,
                       h_c: ca.Function | None = None, G: ca.Function | None = None,
                       D: ca.Function | None = None, name: str = "model") -> "CdModel":
        """Build a model from CasADi functions of ``(x, u, p)``; defaults as in
        :meth:`from_expressions` (``G = −∂f/∂u``, ``D = −∂h_c/∂u``)."""
        f = _as_sx_function(f, "f")
        x, u, p = (ca.SX.sym(s, f.size_in(i)) for i, s in enumerate("xup"))
        xdot = f(x, u, p)
        G_e = None if G is None else _as_sx_function(G, "G")(x, u, p)
        h_e = None if h_c is None else _as_sx_function(h_c, "h_c")(x, u, p)
        D_e = None if D is None else _as_sx_function(D, "D")(x, u, p)
        return cls.from_expressions(layout, x, u, p, xdot, h_c=h_e, G=G_e, D=D_e,
                                    name=name)


@dataclass(frozen=True, eq=False)
class MeasurementModel:
    """One row type of a discrete measurement ``z_i = h(x, p_i) + v_i``.

    Attributes
    ----------
    h : casadi.Function
        ``(x[n], p_row[n_p]) -> z_row[k]``; an update stacks ``m`` rows.
    name : str
    compiled : bool
        Evaluate rows with generated C (:class:`ekf.compiled.CompiledRows`, compiled once
        and cached on disk) when a C compiler is available; else the CasADi VM.
    """

    h: ca.Function
    name: str = "measurement"
    compiled: bool = True

    def __post_init__(self) -> None:
        h = _as_sx_function(self.h, f"measurement {self.name!r}")
        if h.n_in() != 2 or h.n_out() != 1:
            raise ModelError(f"measurement {self.name!r} must map (x, p_row) -> z_row")
        object.__setattr__(self, "h", h)
        # the sizes, asked at every evaluation: read once from the function
        object.__setattr__(self, "_sizes", (h.numel_in(0), h.numel_in(1), h.numel_out(0)))

    @classmethod
    def from_expression(cls, x: ca.SX, p_row: ca.SX, z_row: ca.SX,
                        name: str = "measurement") -> "MeasurementModel":
        """Build from SX symbols ``x (n,1)``, ``p_row (n_p,1)`` and ``z_row (k,1)``."""
        return cls(ca.Function(name, [x, p_row], [z_row], ["x", "p"], ["z"]), name)

    @property
    def n(self) -> int:
        """State dimension."""
        return self._sizes[0]

    @property
    def n_p(self) -> int:
        """Parameters per row."""
        return self._sizes[1]

    @property
    def k(self) -> int:
        """Components per row."""
        return self._sizes[2]

    def evaluate(self, x: npt.ArrayLike, p_rows: npt.ArrayLike) -> tuple[Array, Array]:
        """Predicted measurement and its Jacobian for ``m`` rows.

        Parameters
        ----------
        x : array_like, shape (n,)
        p_rows : array_like, shape (m, n_p)

        Returns
        -------
        z_pred : ndarray, shape (m * k,)
            Rows stacked: ``z_pred[i*k:(i+1)*k] = h(x, p_rows[i])``.
        H : ndarray, shape (m * k, n)
            ``∂z_pred/∂x``.
        """
        p_rows = np.asarray(p_rows, dtype=float)
        if p_rows.ndim != 2 or p_rows.shape[1] != self.n_p:
            raise ModelError(f"measurement {self.name!r}: p_rows must have shape (m, "
                             f"{self.n_p}), got {p_rows.shape}")
        m = p_rows.shape[0]
        if m == 0:
            return np.zeros(0), np.zeros((0, self.n))
        rows = _compiled_rows(self.h) if self.compiled else None
        if rows is not None:
            return rows.run(np.asarray(x, dtype=float), p_rows)
        z, H = _mapped(self.h, m)(to_casadi(np.asarray(x, dtype=float)), to_casadi(p_rows))
        z_pred = to_numpy(z, columns=False).T.reshape(-1)
        H = to_numpy(H, columns=False).reshape(self.k, m, self.n).transpose(1, 0, 2)
        return z_pred, H.reshape(m * self.k, self.n)


def _row_function(h: ca.Function) -> ca.Function:
    """``(x, p) -> (z, H)`` with ``H`` row by row."""
    x = ca.SX.sym("x", h.size_in(0))
    p = ca.SX.sym("p", h.size_in(1))
    z = h(x, p)
    return ca.Function(f"{h.name()}_row", [x, p],
                       [z, ca.vec(ca.densify(ca.jacobian(z, x)).T)])


@lru_cache(maxsize=64)
def _compiled_rows(h: ca.Function) -> "CompiledRows | None":
    """The compiled row loop of ``h`` (None without a C compiler)."""
    if not compiler_available():
        return None
    return CompiledRows(_row_function(h))


@lru_cache(maxsize=256)
def _mapped(h: ca.Function, m: int) -> ca.Function:
    """``h`` and its Jacobian, mapped over ``m`` rows with ``x`` shared (built once)."""
    x = ca.SX.sym("x", h.size_in(0))
    p = ca.SX.sym("p", h.size_in(1))
    z = h(x, p)
    row = ca.Function("row", [x, p], [z, ca.densify(ca.jacobian(z, x))])
    return row.map(f"{h.name()}_rows{m}", "serial", m, [0], [])
