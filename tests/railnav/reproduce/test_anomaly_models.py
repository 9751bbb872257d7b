"""railnav/reproduce/anomaly_models.py against the paper's equations written out element by element
(eqs. 8–13 for one step of the truth, eq. 14/16 non-zero elements) and the noise
covariances of the differenced measurement built from their definition as a linear map of
independent standard normals."""
from __future__ import annotations

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.reproduce.anomaly_models import (
    HORIZONTAL,
    VERTICAL,
    AnomalyParams,
    horizontal_channel,
    vertical_channel,
)

#: Agreement of algebraically equal expressions in double precision.
RTOL = 1e-12
ATOL = 1e-15
G_TEST = 9.8  # any g: the model subtracts the g it is given


def test_horizontal_step_is_paper_eqs_8_to_11(rng):
    p = AnomalyParams()
    ch = horizontal_channel(p)
    T = p.dt
    x, vx, dax = 3.0, -2.0, 0.15
    y, vy, day = -7.0, 5.0, -0.05
    a = np.array([0.4, -0.3])
    state = np.zeros(6)
    state[[HORIZONTAL.index(k) for k in ("north", "east", "v_north", "v_east",
                                         "bias_a_north", "bias_a_east")]] = \
        [x, y, vx, vy, dax, day]
    nxt = ch.Phi @ state + ch.Psi @ a
    expected = {"north": x + T * vx + 0.5 * T**2 * a[0] - 0.5 * T**2 * dax,
                "east": y + T * vy + 0.5 * T**2 * a[1] - 0.5 * T**2 * day,
                "v_north": vx + T * a[0] - T * dax, "v_east": vy + T * a[1] - T * day,
                "bias_a_north": dax, "bias_a_east": day}
    for name, value in expected.items():
        assert nxt[HORIZONTAL.index(name)] == pytest.approx(value, rel=RTOL)
    s = p.sigma_accel_mps2 * np.sqrt(2 * T / p.accel_noise_rate_per_s)   # eq. 1
    Q = ch.Q
    i, v = HORIZONTAL.index("north"), HORIZONTAL.index("v_north")
    assert Q[i, i] == pytest.approx((0.5 * T**2 * s) ** 2, rel=RTOL)
    assert Q[i, v] == pytest.approx(0.5 * T**3 * s**2, rel=RTOL)
    assert Q[v, v] == pytest.approx((T * s) ** 2, rel=RTOL)
    assert Q[i, HORIZONTAL.index("east")] == 0.0
    np.testing.assert_array_equal(np.diag(ch.R_gnss), [25.0, 25.0])
    np.testing.assert_array_equal(np.diag(ch.R_speed), [4.0, 4.0])


def test_vertical_step_is_paper_eqs_12_13():
    p = AnomalyParams()
    ch = vertical_channel(p)
    T = p.dt
    h, vz, dh, daz, az = 1000.0, 0.3, 7.0, 0.2, 0.5
    state = np.array([h, vz, dh, daz])
    assert [VERTICAL.index(k) for k in ("height", "v_up", "baro_bias", "bias_a_up")] == \
        [0, 1, 2, 3]
    nxt = ch.Phi @ state + ch.Psi @ np.array([az + G_TEST, G_TEST])
    np.testing.assert_allclose(nxt, [h + T * vz + 0.5 * T**2 * (az - daz),
                                     vz + T * (az - daz), dh, daz], rtol=RTOL)


def test_differenced_noise_covariances_from_their_definition():
    """v = [H1 w + σ_b(1−φ²)^½ n_u; H2 w + σ_z n_z], w = Γ n_a: a linear map J of the
    independent normals (n_a, n_u, n_z), so E[v vᵀ] = J Jᵀ and E[w vᵀ] = Γ J_aᵀ."""
    p = AnomalyParams()
    ch = vertical_channel(p)
    phi = np.exp(-p.baro_noise_rate_per_s * p.dt)
    J = np.zeros((2, 3))
    J[0, 0] = (ch.H_baro @ ch.Gamma)[0, 0]
    J[1, 0] = (ch.H_gnss @ ch.Gamma)[0, 0]
    J[0, 1] = p.sigma_baro_m * np.sqrt(1 - phi**2)
    J[1, 2] = p.sigma_gnss_height_m
    np.testing.assert_allclose(ch.B_yy, J @ J.T, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(ch.B_xy, ch.Gamma @ J[:, :1].T, rtol=RTOL, atol=ATOL)
    # Φ_yx rows: baro  H(k+1) + ΔH − φ (H(k) + ΔH)  and GNSS H(k+1), from x_k
    T = p.dt
    np.testing.assert_allclose(ch.Phi_yx, [[1 - phi, T, 1 - phi, -0.5 * T**2],
                                           [1, T, 0, -0.5 * T**2]], rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("kwargs", [{"dt": 0.0}, {"sigma_baro_m": -1.0},
                                    {"height_m": float("nan")}, {"P0_vertical": (1.0, 2.0)},
                                    {"P0_horizontal": (1, 1, 1, 1, 1, 0)}])
def test_bad_params_raise(kwargs):
    with pytest.raises(ConfigError):
        AnomalyParams(**kwargs)
