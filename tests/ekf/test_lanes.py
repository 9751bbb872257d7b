"""K members in one compiled call (`ekf.lanes`) against CasADi's own scalar code
(`ekf.compiled.CompiledLoop`) and its virtual machine, member by member: every output of
every step equal to the bit, for every operation the lane writer knows, for member counts
that fill the lanes and that do not; only the outputs asked for are stored; a function
it cannot write is refused before anything is compiled."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ekf.compiled import CompiledLoop, CompileOptions
from ekf.errors import FilterError
from ekf.lanes import LANES, OPERATIONS, CompiledMembers, LanesUnsupported
from ekf.packing import pack_sym
from ekf.propagate import Propagator
from ekf.step import STEP_OUTPUTS, StepData, build_step
from tests.support.ekf_examples import attitude_speed_clock_toy


def _every_operation(name: str) -> ca.Function:
    """A step ``(x[2], P[3], d[2]) -> (x_next, P_next, ops)`` whose third output applies
    every operation of `OPERATIONS` to arguments in its domain (some of them constants:
    π, a negative zero, inf)."""
    x, P, d = ca.SX.sym("x", 2), ca.SX.sym("P", 3), ca.SX.sym("d", 2)
    a = 0.5 * ca.tanh(x[0] + d[0])          # in (-0.5, 0.5): asin, acos, atan, log1p ...
    b = 1.5 + ca.sin(x[1] * d[1]) ** 2      # in [1.5, 2.5]: log, sqrt, pow
    ops = [a + b, a - b, a * b, a / b, -a, a ** 2, 1 / b, ca.sqrt(b), ca.sin(a),
           ca.cos(a), ca.tan(a), ca.asin(a), ca.acos(a), ca.atan(a), ca.exp(a), ca.log(b),
           ca.sinh(a), ca.cosh(a), ca.tanh(b), ca.floor(7 * a), ca.ceil(7 * a),
           ca.fabs(a), ca.erf(a), ca.sign(a), ca.sign(a * 0), ca.logic_not(a > 0),
           b ** a, ca.constpow(b, 2.5), 2 * b, ca.atan2(a, b - 2), ca.fmod(7 * a, b),
           ca.fmin(a, b - 2), ca.fmax(a, b - 2), ca.copysign(b, a), ca.hypot(a, b), a < b - 2, a <= 0,
           a == 0, a != 0, ca.logic_and(a > 0, b > 2), ca.logic_or(a > 0, b > 2),
           ca.if_else(a > 0, b, -b), ca.SX(np.pi) * a, ca.SX(-0.0) + a, ca.SX(np.inf) * 0 + a]
    x_next = ca.vertcat(x[0] + 0.01 * ca.sin(d[0] + x[1]), x[1] + 0.01 * ca.cos(x[0] * d[1]))
    P_next = P * (1.0 - 0.01 * a)
    return ca.Function(name, [x, P, d], [x_next, P_next, ca.vertcat(*ops)])


def _operations_of(fun: ca.Function) -> set:
    return {fun.instruction_id(k) for k in range(fun.n_instructions())} - \
        {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST}


@pytest.mark.parametrize("members", [1, LANES, LANES + 3])
def test_every_operation_equals_casadis_code_to_the_bit(tmp_path, rng, members):
    fun = _every_operation("lanes_ops")
    assert _operations_of(fun) == set(OPERATIONS) - {ca.OP_ASSIGN}
    opts = CompileOptions(cache_dir=str(tmp_path))
    n_steps = 9
    x0, P0 = rng.normal(size=(members, 2)), rng.uniform(1.0, 2.0, (members, 3))
    d = rng.normal(size=(members, n_steps, 2))
    x, P, steps = CompiledMembers(fun, opts).run(x0, P0, d, keep=(0, 1, 2))
    scalar = CompiledLoop(fun, opts)
    for k in range(members):
        expected = scalar.run(x0[k], P0[k], d[k])
        for got, want in zip(steps, expected):
            np.testing.assert_array_equal(got[k], want)
        np.testing.assert_array_equal(x[k], expected[0][-1])
        np.testing.assert_array_equal(P[k], expected[1][-1])
    # CasADi's virtual machine (the library's own evaluation), first step of member 0
    vm = [np.asarray(v).ravel() for v in fun(x0[0], P0[0], d[0, 0])]
    for got, want in zip(steps, vm):
        np.testing.assert_array_equal(got[0, 0], want)


def _toy_members(rng, members: int, n_steps: int):
    model = attitude_speed_clock_toy("lanes_toy")
    u = np.tile([0.1, 0.0, 9.81, 0.0, 0.0, 1e-3], (n_steps + 1, 1))
    rows = []
    for _ in range(members):
        noisy = u + 1e-2 * rng.normal(size=u.shape)
        rows.append(StepData.of(model).assemble(
            u=noisy, p=np.zeros((n_steps, 0)), z_c=1e-3 * rng.normal(size=(n_steps, 2)),
            dt=np.full(n_steps, 0.01), q_c=np.full((n_steps, 6), 1e-8),
            r_c=np.full((n_steps, 2), 1e-6)))
    x0 = np.column_stack([rng.normal(0, 0.1, (members, 3)), rng.normal(0, 1, (members, 4))])
    P0 = pack_sym(np.array([np.diag(rng.uniform(1e-6, 1.0, 7)) for _ in range(members)]))
    return model, x0, P0, np.array(rows)


def test_a_filter_step_equals_the_scalar_loop_and_keeps_what_is_asked(tmp_path, rng):
    """The toy filter's step (trigonometry, Cholesky solves, congruences): each member
    equals `CompiledLoop` to the bit; outputs not kept are None and the kept ones the
    same as when all are kept."""
    model, x0, P0, d = _toy_members(rng, 6, 40)
    opts = CompileOptions(cache_dir=str(tmp_path))
    step = build_step(model)
    members = CompiledMembers(step, opts)
    x, P, every = members.run(x0, P0, d, keep=range(len(STEP_OUTPUTS)))
    scalar = CompiledLoop(step, opts)
    for k in range(len(x0)):
        for got, want in zip(every, scalar.run(x0[k], P0[k], d[k])):
            assert np.all(np.isfinite(want))
            np.testing.assert_array_equal(got[k], want)
    innov, S = STEP_OUTPUTS.index("innov"), STEP_OUTPUTS.index("S")
    x2, P2, some = members.run(x0, P0, d, keep=(innov, S))
    assert [i for i, s in enumerate(some) if s is not None] == [innov, S]
    for i in (innov, S):
        np.testing.assert_array_equal(some[i], every[i])
    np.testing.assert_array_equal(x2, x)
    np.testing.assert_array_equal(P2, P)


def test_propagator_members_equal_run_on_every_backend(tmp_path, rng):
    """`Propagator.run_members`: compiled (one call) and the CasADi VM (member by member)
    give `Propagator.run`'s outputs, the ones not kept None."""
    model, x0, P0, d = _toy_members(rng, 5, 12)
    opts = CompileOptions(cache_dir=str(tmp_path))
    for backend in ("compiled", "casadi"):
        prop = Propagator(model, backend=backend, compile_options=opts)
        x, P, outputs = prop.run_members(x0, P0, d, keep=("x_next", "S", "nis"))
        for k, out in enumerate(outputs):
            one = prop.run(x0[k], P0[k], d[k])
            np.testing.assert_array_equal(x[k], one.x_next[-1])
            np.testing.assert_array_equal(P[k], one.P_next[-1])
            for name in STEP_OUTPUTS:
                if name in ("x_next", "S", "nis"):
                    np.testing.assert_array_equal(getattr(out, name), getattr(one, name))
                else:
                    assert getattr(out, name) is None
            assert out.steps == 12


def test_what_cannot_be_written_for_lanes_is_refused_before_compiling(tmp_path):
    x, P, d = ca.SX.sym("x", 1), ca.SX.sym("P", 1), ca.SX.sym("d", 1)
    opts = CompileOptions(cache_dir=str(tmp_path))
    with pytest.raises(LanesUnsupported, match="not written for lanes"):
        CompiledMembers(ca.Function("erfinv_step", [x, P, d], [ca.erfinv(x), P]), opts)
    mx = [ca.MX.sym(n) for n in "xPd"]
    with pytest.raises(LanesUnsupported):
        CompiledMembers(ca.Function("mx_step", mx, [mx[0] + mx[2], mx[1]]), opts)
    with pytest.raises(LanesUnsupported, match="not a step function"):
        CompiledMembers(ca.Function("two_in", [x, P], [x, P]), opts)
    assert not list(tmp_path.glob("*.so"))


def test_member_shapes_are_checked(tmp_path):
    fun = _every_operation("lanes_shapes")
    members = CompiledMembers(fun, CompileOptions(cache_dir=str(tmp_path)))
    with pytest.raises(FilterError, match="compiled members expect"):
        members.run(np.zeros((2, 2)), np.zeros((2, 3)), np.zeros((3, 4, 2)))
    x, P, steps = members.run(np.ones((2, 2)), np.ones((2, 3)), np.zeros((2, 0, 2)),
                              keep=(2,))
    np.testing.assert_array_equal(x, np.ones((2, 2)))
    assert steps[2].shape == (2, 0, 45)
