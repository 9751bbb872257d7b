"""IMU error statistics against their definitions: white-noise Allan deviation N/√τ,
Gauss–Markov stationary σ and one-step regression, bias/scale/misalignment spread."""
from __future__ import annotations

import math

import numpy as np
import pytest

from strapdown.errors import StrapdownError
from strapdown.imu import Imu
from strapdown.imu_errors import IMU_GRADES, ImuErrors, apply_imu_errors, imu_grade

RATE_HZ = 100.0
N_SAMPLES = 200_000          # 2000 s at 100 Hz
# Estimator spreads: a sample σ from n samples has relative σ 1/sqrt(2n); an Allan
# deviation from K non-overlapping clusters 1/sqrt(2(K-1)). We accept 5 of those σ.
N_SIGMA = 5.0


def zero_imu(n=N_SAMPLES):
    t = np.arange(n) / RATE_HZ
    return Imu(time_s=t, f_b=np.zeros((n, 3)), omega_ib_b=np.zeros((n, 3)))


def allan_deviation(y, m):
    """Non-overlapping Allan deviation at cluster size m (samples), per column."""
    k = len(y) // m
    means = y[: k * m].reshape(k, m, -1).mean(axis=1)
    return np.sqrt(0.5 * np.mean(np.diff(means, axis=0) ** 2, axis=0)), k


def test_white_noise_has_the_specified_density(rng):
    density = 1e-3
    out = apply_imu_errors(zero_imu(), ImuErrors(accel_noise_density_mps2_rthz=density,
                                                 gyro_noise_density_radps_rthz=2 * density), rng)
    for y, n in ((out.f_b, density), (out.omega_ib_b, 2 * density)):
        sample_sigma = n * math.sqrt(RATE_HZ)
        rel = N_SIGMA / math.sqrt(2 * y.size)
        assert np.std(y) == pytest.approx(sample_sigma, rel=rel)
        for tau_s in (0.1, 1.0, 10.0):
            adev, k = allan_deviation(y, int(tau_s * RATE_HZ))
            rel = N_SIGMA / math.sqrt(2 * (3 * k - 3))  # 3 axes pooled
            assert np.sqrt(np.mean(adev ** 2)) == pytest.approx(n / math.sqrt(tau_s), rel=rel)


def test_gauss_markov_bias_instability(rng):
    sigma, tau_s = 2e-4, 0.5
    out = apply_imu_errors(zero_imu(), ImuErrors(accel_bias_instability_mps2=sigma,
                                                 accel_bias_tau_s=tau_s), rng)
    b = out.f_b
    # Stationary σ: about T/(2τ) = 2000 independent values per axis, 3 axes.
    rel = N_SIGMA / math.sqrt(2 * 3 * (N_SAMPLES / RATE_HZ) / (2 * tau_s))
    assert np.std(b) == pytest.approx(sigma, rel=rel)
    # One-step regression b[k+1] = φ b[k] + e: φ = exp(-dt/τ), std(e) = σ sqrt(1 - φ²).
    phi = math.exp(-1 / (RATE_HZ * tau_s))
    x, y = b[:-1].ravel(), b[1:].ravel()
    slope = np.dot(x, y) / np.dot(x, x)
    assert slope == pytest.approx(phi, abs=N_SIGMA * math.sqrt((1 - phi ** 2) / x.size))
    resid_sigma = sigma * math.sqrt(1 - phi ** 2)
    assert np.std(y - slope * x) == pytest.approx(resid_sigma, rel=rel)


def test_constant_bias_scale_factor_and_misalignment_spread():
    """Over many runs, the per-run draws have the specified σ (input ω = [1, 2, 3] rad/s)."""
    err = ImuErrors(gyro_bias_radps=1e-4, gyro_scale_factor_ppm=500.0,
                    gyro_misalignment_rad=1e-3)
    runs = 2000
    t = np.array([0.0, 0.01])
    omega = np.array([[1.0, 0.0, 0.0]] * 2)
    outputs = np.array([apply_imu_errors(Imu(t, np.zeros((2, 3)), omega), err,
                                         np.random.default_rng(seed)).omega_ib_b[0]
                        for seed in range(runs)])
    f_bias = np.array([apply_imu_errors(Imu(t, np.zeros((2, 3)), np.zeros((2, 3))), err,
                                        np.random.default_rng(seed)).omega_ib_b[0]
                       for seed in range(runs)])
    rel = N_SIGMA / math.sqrt(2 * runs)
    # x axis: 1 + sf + bias; y, z axes: misalignment + bias.
    assert np.std(f_bias) == pytest.approx(1e-4, rel=rel)
    assert np.std(outputs[:, 0] - f_bias[:, 0]) == pytest.approx(500e-6, rel=rel)
    assert np.std(outputs[:, 1:] - f_bias[:, 1:]) == pytest.approx(1e-3, rel=rel)


def test_perfect_returns_the_input_and_presets_are_valid(rng):
    imu = zero_imu(10)
    assert apply_imu_errors(imu, "perfect", rng) is imu
    assert set(IMU_GRADES) == {"perfect", "paper2017", "navigation", "tactical", "mems"}
    assert imu_grade("paper2017").accel_noise_density_mps2_rthz == 1e-5  # paper's (1e-5)²·s
    with pytest.raises(StrapdownError, match="unknown IMU grade"):
        imu_grade("bogus")
    with pytest.raises(StrapdownError, match="accel_bias_mps2"):
        ImuErrors(accel_bias_mps2=float("nan"))


def test_same_seed_same_errors():
    imu = zero_imu(100)
    a = apply_imu_errors(imu, "mems", np.random.default_rng(5))
    b = apply_imu_errors(imu, "mems", np.random.default_rng(5))
    np.testing.assert_array_equal(a.f_b, b.f_b)


def test_draw_order_of_a_noise_only_grade():
    """The paper's grade (white noise only): each triad draws scale (3), misalignment
    (3, 3), bias (3), Gauss–Markov start (3) and drive (n, 3), then noise (n, 3), all
    made whether or not the term is zero. Reference: the same draws from a generator of
    the same seed, written out here; the result must be equal to the bit (the paper's
    reproduction depends on it)."""
    n, seed = 1000, 12
    grade = IMU_GRADES["paper2017"]
    truth = zero_imu(n)
    out = apply_imu_errors(truth, grade, np.random.default_rng(seed))
    rng = np.random.default_rng(seed)
    expected = []
    for density in (grade.accel_noise_density_mps2_rthz, grade.gyro_noise_density_radps_rthz):
        for shape in ((3,), (3, 3), (3,), (3,), (n, 3)):
            rng.standard_normal(shape)
        expected.append(density * math.sqrt(RATE_HZ) * rng.standard_normal((n, 3)))
    np.testing.assert_array_equal(out.f_b, expected[0])
    np.testing.assert_array_equal(out.omega_ib_b, expected[1])


def test_gauss_markov_recursion_is_lfilter_to_the_bit(rng):
    """Reference: ``scipy.signal.lfilter`` of the same first-order filter and state."""
    from scipy.signal import lfilter
    from strapdown.imu_errors import gauss_markov_recursion
    drive = rng.standard_normal((5000, 3))
    phi, gain = math.exp(-0.01 / 300.0), 3e-4
    start = 1e-3 * rng.standard_normal(3)
    ref = lfilter([gain], [1.0, -phi], drive, axis=0, zi=(phi * start)[None, :])[0]
    assert np.array_equal(gauss_markov_recursion(drive, gain=gain, phi=phi, start=start), ref)


@pytest.mark.parametrize("n_rows", [1, 8191, 8192, 8193, 100_001])
def test_rows_times_is_the_whole_product_to_the_bit(rng, n_rows):
    """Reference: ``rows @ matrix.T`` in one call (second method: one product, which
    OpenBLAS splits over threads above ~30 000 rows); the blocked product must give the
    same bits, so that the simulated IMU does not change."""
    from strapdown.imu_errors import rows_times
    rows = rng.standard_normal((n_rows, 3)) * 1e3
    matrix = np.eye(3) + 1e-3 * rng.standard_normal((3, 3))
    assert np.array_equal(rows_times(rows, matrix), rows @ matrix.T)
