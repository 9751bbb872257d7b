"""The compiled step loop and its disk cache: a hit generates no code and compiles
nothing; the directory comes from the options, ``$RAILNAV_CACHE_DIR`` or the user cache
directory; concurrent processes compile a library once; an unwritable directory still
runs (compiled privately, with a warning); a broken compiler is a FilterError."""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ekf.compiled as compiled
from ekf.compiled import CompiledLoop, CompileOptions
from ekf.errors import FilterError
from ekf.library_cache import default_cache_dir, user_cache_dir
from ekf.packing import pack_sym
from ekf.propagate import Propagator
from ekf.step import StepData, build_step
from tests.support.ekf_examples import attitude_speed_clock_toy

REPO = Path(__file__).resolve().parents[2]


def _data(name: str) -> np.ndarray:
    return StepData.of(attitude_speed_clock_toy(name)).assemble(
        u=np.tile([0, 0, 9.81, 0, 0, 0], (4, 1)), p=np.zeros((3, 0)), z_c=np.zeros((3, 2)),
        dt=np.full(3, 0.01), q_c=np.full((3, 6), 1e-10), r_c=np.zeros((3, 2)))


def test_cache_hit_and_backends_agree(tmp_path):
    opts = CompileOptions(cache_dir=str(tmp_path))
    step = build_step(attitude_speed_clock_toy("cachecheck"))
    first = CompiledLoop(step, opts)
    second = CompiledLoop(step, opts)
    assert len(list(tmp_path.glob("*.so"))) == 1 and second.compile_seconds == 0.0
    assert first.compile_seconds > 0.0
    d = _data("cachecheck")
    x0, P0 = np.zeros(7), pack_sym(np.eye(7))
    a = first.run(x0, P0, d)
    b = Propagator(attitude_speed_clock_toy("cachecheck"), backend="casadi").run(x0, P0, d)
    np.testing.assert_allclose(a[1], b.P_next, rtol=1e-12)


def test_a_cache_hit_generates_no_code(tmp_path, monkeypatch):
    """The key is the function's hash: a hit needs neither the code generator nor gcc."""
    opts = CompileOptions(cache_dir=str(tmp_path))
    step = build_step(attitude_speed_clock_toy("keycheck"))
    CompiledLoop(step, opts)

    def no_codegen(*args):
        raise AssertionError("code generated on a cache hit")
    monkeypatch.setattr(compiled, "_c_source", no_codegen)
    again = CompiledLoop(build_step(attitude_speed_clock_toy("keycheck")), opts)
    assert again.compile_seconds == 0.0
    # another compiler command is another library
    with pytest.raises(AssertionError, match="code generated"):
        CompiledLoop(step, CompileOptions(cache_dir=str(tmp_path), flags=("-O1",)))


@pytest.mark.parametrize("native", [False, True])
def test_native_and_inline_flags_change_no_bit(tmp_path, rng, native):
    """`INLINE_FLAGS` and `NATIVE_FLAGS` are for speed only: the same outputs, to the bit,
    as ``-O2`` alone (a step with trigonometry, Cholesky solves and congruences, over
    random inputs)."""
    if native and not compiled.has_avx2():
        pytest.skip("no AVX2 on this processor")
    model = attitude_speed_clock_toy("nativecheck")
    step = build_step(model)
    n_steps = 50
    u = np.tile([0.1, 0.0, 9.81, 0.0, 0.0, 1e-3], (n_steps + 1, 1)) \
        + 1e-2 * rng.normal(size=(n_steps + 1, 6))
    d = StepData.of(model).assemble(u=u, p=np.zeros((n_steps, 0)),
                                    z_c=1e-3 * rng.normal(size=(n_steps, 2)),
                                    dt=np.full(n_steps, 0.01), q_c=np.full((n_steps, 6), 1e-8),
                                    r_c=np.full((n_steps, 2), 1e-6))
    x0 = np.concatenate([rng.normal(0, 0.1, 3), rng.normal(0, 1, 4)])
    P0 = pack_sym(np.diag(rng.uniform(1e-6, 1.0, 7)))
    flags = ("-O2", *compiled.INLINE_FLAGS, *(compiled.NATIVE_FLAGS if native else ()))
    fast = CompiledLoop(step, CompileOptions(cache_dir=str(tmp_path), flags=flags))
    plain = CompiledLoop(step, CompileOptions(cache_dir=str(tmp_path), flags=("-O2",)))
    assert len(list(tmp_path.glob("*.so"))) == 2
    for a, b in zip(fast.run(x0, P0, d), plain.run(x0, P0, d)):
        assert np.all(np.isfinite(a)) and np.array_equal(a, b)


@pytest.mark.skipif(not compiled.has_avx2(), reason="no AVX2 on this processor")
def test_native_flags_change_no_bit_of_geodetic_rows(tmp_path, rng):
    """The unconstrained filter's range-rate rows (where ``-march=native`` formed a
    ``vfmaddsub`` on AVX-512 and changed the Jacobian's last bit): equal to ``-O2``."""
    from ekf.compiled import CompiledRows
    from ekf.model import _row_function
    from railnav.config import NavigatorConfig
    from railnav.filters.protocol import make_filter
    from trackmodel.io import read_track
    track = read_track(REPO / "data" / "tracks" / "paper2017.csv")
    rows = make_filter(track, NavigatorConfig(filter="unconstrained"), None).rows.rows
    x = np.zeros(rows.range_rate.n)
    x[:9] = [0.1, 0.01, 0.02, 20.0, 1.0, 0.1, 0.7, 0.1, 100.0]
    for model in (rows.pseudorange, rows.range_rate):
        fun = _row_function(model.h)
        p = np.column_stack([rng.normal(2e7, 5e6, (40, 3)),
                             rng.normal(0, 1e3, (40, model.n_p - 3))])
        native = CompiledRows(fun, CompileOptions(cache_dir=str(tmp_path),
                                                  flags=("-O2", *compiled.INLINE_FLAGS,
                                                         *compiled.NATIVE_FLAGS)))
        plain = CompiledRows(fun, CompileOptions(cache_dir=str(tmp_path), flags=("-O2",)))
        for a, b in zip(native.run(x, p), plain.run(x, p)):
            assert np.array_equal(a, b)


def test_native_flags_only_with_avx2_and_never_fma():
    """The default flags are the portable ``-O2`` unless the processor has AVX2; no flag
    may enable fused multiply-adds (other bits) or tune for the compiling machine."""
    expected = ("-O2", *compiled.INLINE_FLAGS,
                *(compiled.NATIVE_FLAGS if compiled.has_avx2() else ()))
    assert CompileOptions().flags == expected
    assert not any(f.startswith(("-march", "-mfma", "-mavx512", "-ffast-math", "-O3"))
                   for f in (*compiled.INLINE_FLAGS, *compiled.NATIVE_FLAGS))
    assert "-ffp-contract=off" in compiled.NATIVE_FLAGS


def test_cache_directory_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("RAILNAV_CACHE_DIR", str(tmp_path / "root"))
    assert CompileOptions().directory() == tmp_path / "root" / "ekf"
    assert CompileOptions(cache_dir=str(tmp_path)).directory() == tmp_path
    monkeypatch.delenv("RAILNAV_CACHE_DIR")
    if sys.platform.startswith("linux"):        # the XDG convention (platformdirs')
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
        assert default_cache_dir() == tmp_path / "xdg" / "railnav" / "ekf"
        monkeypatch.delenv("XDG_CACHE_HOME")
        assert user_cache_dir() == Path.home() / ".cache" / "railnav"


def test_unwritable_cache_directory_still_runs(tmp_path, caplog):
    """A cache directory that cannot be created (below a regular file; chmod would not
    stop root) compiles privately and warns once; nothing is written."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    opts = CompileOptions(cache_dir=str(blocker / "cache"))
    with caplog.at_level(logging.WARNING, logger="ekf.library_cache"):
        loop = CompiledLoop(build_step(attitude_speed_clock_toy("readonly")), opts)
        again = CompiledLoop(build_step(attitude_speed_clock_toy("readonly")), opts)
    assert loop.compile_seconds > 0.0 and again.compile_seconds > 0.0
    warnings = [r for r in caplog.records if "not writable" in r.getMessage()]
    assert len(warnings) == 1 and "RAILNAV_CACHE_DIR" in warnings[0].getMessage()
    x0, P0 = np.zeros(7), pack_sym(np.eye(7))
    np.testing.assert_array_equal(loop.run(x0, P0, _data("readonly"))[1],
                                  again.run(x0, P0, _data("readonly"))[1])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


#: Build the toy's loop into the cache directory argv[1]; print the compile seconds.
WORKER = """
import json, sys
from ekf.compiled import CompiledLoop, CompileOptions
from ekf.step import build_step
from tests.support.ekf_examples import attitude_speed_clock_toy
loop = CompiledLoop(build_step(attitude_speed_clock_toy("concurrent")),
                    CompileOptions(cache_dir=sys.argv[1]))
print(json.dumps(loop.compile_seconds))
"""


@pytest.mark.skipif(not hasattr(os, "fork") or sys.platform == "win32",
                    reason="the lock is fcntl's")
def test_concurrent_processes_compile_once(tmp_path):
    """Two processes started together on an empty cache: one compiles, the other waits
    for its lock and loads the library (reference: the file count and the timings)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    procs = [subprocess.Popen([sys.executable, "-c", WORKER, str(tmp_path)], cwd=REPO,
                              env=env, stdout=subprocess.PIPE, text=True) for _ in range(2)]
    seconds = [json.loads(p.communicate(timeout=300)[0]) for p in procs]
    assert all(p.returncode == 0 for p in procs)
    assert sorted(s > 0 for s in seconds) == [False, True], seconds
    assert len(list(tmp_path.glob("*.so"))) == 1
    assert not [p for p in tmp_path.iterdir() if p.is_dir()]      # no partial build left


def test_broken_compiler_is_reported(tmp_path):
    step = build_step(attitude_speed_clock_toy("brokencc"))
    with pytest.raises(FilterError, match="compiling"):
        CompiledLoop(step, CompileOptions(compiler="false", cache_dir=str(tmp_path)))
    assert not list(tmp_path.glob("*.so"))


def test_address_is_the_arrays_data_pointer():
    """`compiled.address` (a ctypes view of the buffer) gives ``ndarray.ctypes.data``: of
    writable arrays of each shape the loops pass, of a read-only one and of an empty one
    (the ctypes attribute's own answer)."""
    arrays = [np.zeros(7), np.ones((5, 13)), np.arange(4, dtype=np.int64), np.zeros(0)]
    frozen = np.linspace(0.0, 1.0, 9)
    frozen.flags.writeable = False
    for a in [*arrays, frozen, np.zeros((3, 4))[1]]:
        assert compiled.address(a) == a.ctypes.data


def test_compiled_each_evaluates_every_pair(tmp_path):
    """`CompiledEach` of ``(a, p) -> (a0 p0 + sin p1, [a1 p0, p1 - a0])`` over 3 rows ``a``
    and 4 rows ``p``: each pair's outputs are the closed form's, in (K, m) and (K, m, 2)
    arrays; no rows ``p``: empty arrays; a row of the wrong length: `FilterError`."""
    import casadi as ca

    from ekf.compiled_each import CompiledEach
    a, p = ca.SX.sym("a", 2), ca.SX.sym("p", 2)
    fun = ca.Function("pairs", [a, p], [a[0] * p[0] + ca.sin(p[1]),
                                         ca.vertcat(a[1] * p[0], p[1] - a[0])])
    each = CompiledEach(fun, CompileOptions(cache_dir=str(tmp_path)))
    A = np.array([[1.0, 2.0], [-0.5, 3.0], [4.0, 0.25]])
    P = np.array([[0.1, 0.2], [1.0, -1.0], [2.5, 0.0], [-3.0, 7.0]])
    first, second = each.run(A, P)
    assert first.shape == (3, 4) and second.shape == (3, 4, 2)
    np.testing.assert_allclose(first, A[:, :1] * P[:, 0] + np.sin(P[:, 1]), rtol=1e-15)
    np.testing.assert_allclose(second[..., 0], A[:, 1:] * P[:, 0], rtol=1e-15)
    np.testing.assert_allclose(second[..., 1], P[:, 1] - A[:, :1], rtol=1e-15)
    empty = each.run(A, np.zeros((0, 2)))
    assert empty[0].shape == (3, 0) and empty[1].shape == (3, 0, 2)
    with pytest.raises(FilterError, match="expects rows"):
        each.run(A, np.zeros((4, 3)))
