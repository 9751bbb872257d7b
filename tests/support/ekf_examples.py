"""Example models of the ekf tests and benchmark: small and documented (not shipped in `ekf`).

:func:`attitude_speed_clock_toy` has the *shape* of a track-constrained navigator —
state ``[yaw, pitch, roll, s, v, clock_bias, clock_drift]`` (rad, rad, rad, m, m/s, m,
m/s), input ``[f_b (3), omega_ib_b (3)]`` (m/s², rad/s), a 2-D continuous
pseudo-measurement from the accelerometers — but deliberately simple physics (flat,
non-rotating Earth, body x along the path, Z-Y-X Euler angles). It is NOT the rail
model; it only makes the engine's cost and numerics measurable at the right size.

Dynamics (``g`` = :data:`G_TOY`)::

    roll'  = ω_x + tan(pitch) (ω_y sin(roll) + ω_z cos(roll))
    pitch' = ω_y cos(roll) − ω_z sin(roll)
    yaw'   = (ω_y sin(roll) + ω_z cos(roll)) / cos(pitch)
    s' = v,   v' = f_x − g sin(pitch),   bias' = drift,   drift' = 0

Pseudo-measurement (zero when the vehicle stays on its path)::

    h_c = [f_y + g cos(pitch) sin(roll) − v ω_z,   f_z − g cos(pitch) cos(roll) + v ω_y]
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np

from ekf.layout import StateLayout
from ekf.model import CdModel
from tests.support.ekf_reference import NumpyModel

__all__ = ["G_TOY", "TOY_LAYOUT", "attitude_speed_clock_toy", "attitude_speed_clock_numpy"]

#: Gravity of the toy, m/s².
G_TOY = 9.81

#: State layout of the toy.
TOY_LAYOUT = StateLayout.from_blocks([("att", ("yaw", "pitch", "roll")), ("s", 1), ("v", 1),
                                      ("clock_bias", 1), ("clock_drift", 1)])

_CASADI = SimpleNamespace(sin=ca.sin, cos=ca.cos, tan=ca.tan, stack=lambda *a: ca.vertcat(*a))
_NUMPY = SimpleNamespace(sin=np.sin, cos=np.cos, tan=np.tan, stack=lambda *a: np.array(a))


def _f(lib: SimpleNamespace, x, u):
    pitch, roll, v = x[1], x[2], x[4]
    wx, wy, wz, fx = u[3], u[4], u[5], u[0]
    across = wy * lib.sin(roll) + wz * lib.cos(roll)
    return lib.stack(across / lib.cos(pitch), wy * lib.cos(roll) - wz * lib.sin(roll),
                     wx + lib.tan(pitch) * across, v, fx - G_TOY * lib.sin(pitch), x[6], 0 * v)


def _h(lib: SimpleNamespace, x, u):
    pitch, roll, v = x[1], x[2], x[4]
    return lib.stack(u[1] + G_TOY * lib.cos(pitch) * lib.sin(roll) - v * u[5],
                     u[2] - G_TOY * lib.cos(pitch) * lib.cos(roll) + v * u[4])


def attitude_speed_clock_toy(name: str = "toy7") -> CdModel:
    """The 7-state toy as a :class:`~ekf.model.CdModel` (``n_u = n_w = 6``, ``n_p = 0``,
    ``n_c = 2``; ``G = −∂f/∂u``, ``D = −∂h_c/∂u``)."""
    x, u, p = ca.SX.sym("x", TOY_LAYOUT.size), ca.SX.sym("u", 6), ca.SX.sym("p", 0)
    return CdModel.from_expressions(TOY_LAYOUT, x, u, p, _f(_CASADI, x, u),
                                    h_c=_h(_CASADI, x, u), name=name)


def _F_x(x, u, p):
    pitch, roll, v = x[1], x[2], x[4]
    wy, wz = u[4], u[5]
    sr, cr, cp, tp = np.sin(roll), np.cos(roll), np.cos(pitch), np.tan(pitch)
    across = wy * sr + wz * cr
    d_across = wy * cr - wz * sr
    F = np.zeros((7, 7))
    F[0, 1] = across * tp / cp
    F[0, 2] = d_across / cp
    F[1, 2] = -wy * sr - wz * cr
    F[2, 1] = across / cp ** 2
    F[2, 2] = tp * d_across
    F[3, 4] = 1.0
    F[4, 1] = -G_TOY * cp
    F[5, 6] = 1.0
    return F


def _G(x, u, p):
    pitch, roll = x[1], x[2]
    sr, cr, cp, tp = np.sin(roll), np.cos(roll), np.cos(pitch), np.tan(pitch)
    Fu = np.zeros((7, 6))
    Fu[0, 4:6] = [sr / cp, cr / cp]
    Fu[1, 4:6] = [cr, -sr]
    Fu[2, 3:6] = [1.0, tp * sr, tp * cr]
    Fu[4, 0] = 1.0
    return -Fu


def _H(x, u, p):
    pitch, roll, v = x[1], x[2], x[4]
    sp, cp, sr, cr = np.sin(pitch), np.cos(pitch), np.sin(roll), np.cos(roll)
    H = np.zeros((2, 7))
    H[0, 1:3] = [-G_TOY * sp * sr, G_TOY * cp * cr]
    H[0, 4] = -u[5]
    H[1, 1:3] = [G_TOY * sp * cr, G_TOY * cp * sr]
    H[1, 4] = u[4]
    return H


def _D(x, u, p):
    v = x[4]
    Hu = np.zeros((2, 6))
    Hu[0, 1], Hu[0, 5] = 1.0, -v
    Hu[1, 2], Hu[1, 4] = 1.0, v
    return -Hu


def attitude_speed_clock_numpy() -> NumpyModel:
    """The same toy as NumPy callables with hand-written Jacobians."""
    return NumpyModel(f=lambda x, u, p: _f(_NUMPY, x, u), F_x=_F_x, G=_G,
                      h_c=lambda x, u, p: _h(_NUMPY, x, u), H_c=_H, D=_D)
