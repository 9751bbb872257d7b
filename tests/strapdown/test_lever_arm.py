"""The IMU's lever arm (`strapdown.lever_arm`): a rigid body's specific force at two points,
in closed form."""
from __future__ import annotations

import numpy as np

from strapdown.imu import Imu
from strapdown.lever_arm import move_specific_force

G = 9.80665


def test_rigid_rotation_with_angular_acceleration():
    """The reference point stands (f = (0, 0, g)); the body yaws with ω_z = α t. A point at
    r = (F, L, U) feels ω̇ × r = α (−L, F, 0) and ω × (ω × r) = −ω² (F, L, 0)."""
    t = np.arange(0.0, 10.0, 0.01)
    alpha = 0.01
    w = np.column_stack([np.zeros_like(t), np.zeros_like(t), alpha * t])
    ref = Imu(t, np.tile([0.0, 0.0, G], (t.size, 1)), w)
    F, L, U = 12.0, -1.5, 3.0
    at_r = move_specific_force(ref, (F, L, U))
    wz = alpha * t
    expected = np.column_stack([-alpha * L - wz ** 2 * F, alpha * F - wz ** 2 * L,
                                np.full_like(t, G)])
    inner = (t > 0.2) & (t < 9.8)            # the smoothing window is one-sided at the ends
    np.testing.assert_allclose(at_r.f_b[inner], expected[inner], atol=1e-10)
    back = move_specific_force(at_r, (-F, -L, -U))
    np.testing.assert_allclose(back.f_b[inner], ref.f_b[inner], atol=1e-10)
    assert move_specific_force(ref, (0.0, 0.0, 0.0)) is ref
    np.testing.assert_array_equal(at_r.omega_ib_b, w)
