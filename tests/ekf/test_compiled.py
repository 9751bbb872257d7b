"""The compiled step loop: a disk-cache hit compiles nothing; a broken compiler is a
FilterError, not a crash."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.compiled import CompiledLoop, CompileOptions
from ekf.errors import FilterError
from ekf.packing import pack_sym
from ekf.propagate import Propagator
from ekf.step import StepData, build_step
from tests.support.ekf_examples import attitude_speed_clock_toy


def test_cache_hit_and_backends_agree(tmp_path):
    opts = CompileOptions(cache_dir=str(tmp_path))
    step = build_step(attitude_speed_clock_toy("cachecheck"))
    first = CompiledLoop(step, opts)
    second = CompiledLoop(step, opts)
    assert len(list(tmp_path.glob("*.so"))) == 1 and second.compile_seconds == 0.0
    d = StepData.of(attitude_speed_clock_toy("cachecheck")).assemble(
        u=np.tile([0, 0, 9.81, 0, 0, 0], (4, 1)), p=np.zeros((3, 0)), z_c=np.zeros((3, 2)),
        dt=np.full(3, 0.01), q_c=np.full((3, 6), 1e-10), r_c=np.zeros((3, 2)))
    x0, P0 = np.zeros(7), pack_sym(np.eye(7))
    a = first.run(x0, P0, d)
    b = Propagator(attitude_speed_clock_toy("cachecheck"), backend="casadi").run(x0, P0, d)
    np.testing.assert_allclose(a[1], b.P_next, rtol=1e-12)


def test_broken_compiler_is_reported(tmp_path):
    step = build_step(attitude_speed_clock_toy("brokencc"))
    with pytest.raises(FilterError, match="compiling"):
        CompiledLoop(step, CompileOptions(compiler="false", cache_dir=str(tmp_path)))
