"""imu.csv: exact round trip at full precision, and located one-line errors (a jittered
log with dropped samples is read as it is: `tests/strapdown/test_imu_log.py`)."""
from __future__ import annotations

import numpy as np
import pytest

from strapdown.errors import ImuInputError
from strapdown.imu import IMU_COLUMNS, Imu, read_imu_csv


def test_round_trip_is_exact(tmp_path, rng):
    n = 50
    imu = Imu(np.arange(n) * 0.01, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 1e-3)
    path = tmp_path / "imu.csv"
    imu.to_frame().to_csv(path, index=False, float_format="%.17g")
    back = read_imu_csv(path)
    np.testing.assert_array_equal(back.f_b, imu.f_b)
    np.testing.assert_array_equal(back.omega_ib_b, imu.omega_ib_b)
    assert back.dt == pytest.approx(0.01, rel=1e-12)
    assert imu.u.shape == (n, 6)


@pytest.mark.parametrize("text, match", [
    ("time_s,ax_mps2\n0,1\n", "missing columns"),
    (",".join(IMU_COLUMNS) + "\n0,1,2,3,4,5,6\n0.01,1,x,3,4,5,6\n", "row 2, ay_mps2"),
    (",".join(IMU_COLUMNS) + "\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,nan\n", "row 2, wz_radps"),
    (",".join(IMU_COLUMNS) + "\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n0.005,1,2,3,4,5,6\n",
     r"row 3, time_s: time does not increase \(0.005 after 0.01\)"),
    (",".join(IMU_COLUMNS) + "\n0,1,2,3,4,5,6\n", "at least 2"),
    ("", "empty file"),
])
def test_bad_files_raise_located_errors(tmp_path, text, match):
    path = tmp_path / "imu.csv"
    path.write_text(text)
    with pytest.raises(ImuInputError, match=match) as info:
        read_imu_csv(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_shape_checked():
    with pytest.raises(ImuInputError, match="shape|must be"):
        Imu(np.zeros(3), np.zeros((3, 2)), np.zeros((3, 3)))
