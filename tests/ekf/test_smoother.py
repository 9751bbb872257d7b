"""RTS smoother (ekf/smoother.py) against an independent batch weighted least-squares
smoother of the same linear-Gaussian problem, which keeps the process/measurement noise
correlation as joint 3×3 blocks (no decorrelation) and solves the normal equations."""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg as sla

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.model import MeasurementModel
from ekf.packing import unpack_sym
from ekf.series import Epoch, InputSeries
from ekf.smoother import rts_smooth
from ekf.update import Observation

#: Normal equations of ~120 unknowns, condition ~1e4: relative agreement.
RTOL_BATCH = 1e-8
DT, STEPS = 0.01, 60
Q_C, R_C, R_POS = np.array([0.7, 0.2]), np.array([0.05]), 0.05
EPOCHS = (0, 25, 50, 60)  # samples with a discrete position measurement


def _batch(sys_, x0, P0, z_c, z_d):
    disc = sys_.discrete(DT, Q_C, R_C)
    Phi, H = disc["Phi"], sys_.H
    joint = np.block([[disc["Q"], disc["M"]], [disc["M"].T, disc["R"]]])
    n, size = 2, 2 * (STEPS + 1)
    info, vec = np.zeros((size, size)), np.zeros(size)

    def add(J, r, cov):  # residual r − J X with covariance cov
        W = np.linalg.inv(cov)
        info[:] += J.T @ W @ J
        vec[:] += J.T @ W @ r

    J0 = np.zeros((n, size))
    J0[:, :n] = np.eye(n)
    add(J0, x0, P0)
    for k in range(STEPS):
        J = np.zeros((3, size))
        J[:2, n * (k + 1):n * (k + 2)] = -np.eye(n)  # residual rows: [w_k; v_k] =
        J[:2, n * k:n * (k + 1)] = Phi  # [x_{k+1} − Φ x_k; z_k − H x_k]
        J[2:, n * k:n * (k + 1)] = H
        add(J, np.concatenate([np.zeros(2), z_c[k]]), joint)
    for k, z in z_d.items():
        J = np.zeros((1, size))
        J[0, n * k] = 1.0
        add(J, np.array([z]), np.array([[R_POS]]))
    cov = np.linalg.inv(info)
    mean = cov @ vec
    blocks = np.array([cov[n * k:n * (k + 1), n * k:n * (k + 1)] for k in range(STEPS + 1)])
    return mean.reshape(STEPS + 1, n), blocks


def test_rts_equals_batch_least_squares(tracking_system, linear_system, rng):
    # full-rank G so that the joint (w, v) covariance blocks are invertible
    sys_ = linear_system(A=tracking_system.A, G=np.array([[0.2, 0.0], [1.0, 0.3]]),
                         H=tracking_system.H, D=tracking_system.D)
    model = sys_.model("smooth")
    t = np.arange(STEPS + 1) * DT
    z_c = rng.normal(size=(STEPS + 1, 1))
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 0)
    pos = MeasurementModel.from_expression(x, p, x[0], "pos")
    z_d = {k: rng.normal() for k in EPOCHS}
    epochs = [Epoch(t[k], [Observation(pos, np.array([[z]]), np.array([R_POS]),
                                       np.zeros((1, 0)))]) for k, z in z_d.items()]
    x0, P0 = np.array([0.2, 0.1]), np.diag([1.5, 0.8])
    res = CdFilter(model, FilterConfig(smoothing=True)).run(
        InputSeries(t=t, u=np.zeros((STEPS + 1, 0)), q_c=Q_C, z_c=z_c, r_c=R_C), epochs,
        x0=x0, P0=P0)
    smooth = rts_smooth(res.smoother, res.x_final, res.P_final)
    mean, blocks = _batch(sys_, x0, P0, z_c, z_d)
    np.testing.assert_allclose(smooth.x, mean, rtol=RTOL_BATCH, atol=1e-12)
    # covariances relative to σ_i σ_j (an off-diagonal entry near 0 has no relative scale)
    sigma = np.sqrt(np.diagonal(blocks, axis1=1, axis2=2))
    scale = sigma[:, :, None] * sigma[:, None, :]
    assert np.all(np.abs(unpack_sym(smooth.P) - blocks) <= RTOL_BATCH * scale)
    # the smoother never has larger variance than the filter
    filt_var = np.diagonal(unpack_sym(res.smoother.P_filt), axis1=1, axis2=2)
    assert np.all(np.diagonal(unpack_sym(smooth.P), axis1=1, axis2=2)[:-1]
                  <= filt_var * (1 + RTOL_BATCH))
