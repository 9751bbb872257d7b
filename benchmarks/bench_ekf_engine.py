"""Speed of the estimation engine on a run of the paper's shape.

The 7-state toy of ``tests/support/ekf_examples.py`` (state [yaw, pitch, roll, s, v, clock bias, clock
drift], 6-D IMU input, 2-D continuous pseudo-measurement at every step), 100 000 steps
at 100 Hz (1000 s), 1000 discrete updates of 10 pseudorange-like + 10 Doppler-like rows.
Timed in one process, same data:

* ``compiled``   — the engine's default: generated C loop, one ctypes call per span;
* ``casadi``     — CasADi virtual machine, ``mapaccum`` blocks;
* ``casadi-jit`` — the same blocks JIT-compiled by CasADi (``compiler="shell"``);
* ``numpy``      — the plain NumPy loop of the same algorithm (tests/support/ekf_reference.py) with
  the same discrete updates (NumPy measurement rows + ekf.update.kalman_update); timed
  on a fraction of the run and scaled (it is slow).

The engine backends share the discrete-update path (measurement rows compiled to C when
a compiler is found); they differ in how the 100 steps between updates are run.

Writes ``benchmarks/results/ekf_engine.json``. Run: ``python benchmarks/bench_ekf_engine.py``.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.compiled import CompileOptions
from ekf.model import MeasurementModel
from ekf.series import Epoch, InputSeries
from ekf.update import Observation, kalman_update

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # the example model and the NumPy loop are test support
from tests.support.ekf_examples import (attitude_speed_clock_numpy,  # noqa: E402
                                        attitude_speed_clock_toy)
from tests.support.ekf_reference import reference_step  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "ekf_engine.json"
DT = 0.01  # s, 100 Hz IMU
STEPS = 100_000
EPOCH_EVERY = 100  # steps: 1 Hz GNSS
ROWS = 10  # satellites per epoch (pseudorange + Doppler each)
Q_C = np.array([1e-10] * 3 + [1e-12] * 3)  # (m/s²)²·s, (rad/s)²·s
SIGMA2_PR, SIGMA2_DOPPLER = 15.0, 0.5  # m², (m/s)²: paper 2017
SAT_DISTANCE = 2.2e7  # m


def _measurements() -> tuple[MeasurementModel, MeasurementModel]:
    """Range-like and range-rate-like rows (position = s along a fixed direction)."""
    x, p = ca.SX.sym("x", 7), ca.SX.sym("p", 6)
    r = ca.vertcat(x[3], 0, 0)
    los = p[:3] - r
    dist = ca.norm_2(los)
    rho = dist + x[5]
    rate = ca.dot(los, p[3:] - ca.vertcat(x[4], 0, 0)) / dist + x[6]
    return (MeasurementModel.from_expression(x, p, rho, "pseudorange"),
            MeasurementModel.from_expression(x, p, rate, "doppler"))


def _scenario(rng: np.random.Generator):
    t = np.arange(STEPS + 1) * DT
    u = np.zeros((STEPS + 1, 6))
    u[:, 0] = 0.01 * np.sin(0.01 * t)
    u[:, 2] = 9.81
    u += rng.normal(size=u.shape) * np.sqrt(Q_C / DT)
    pr, dop = _measurements()
    sats = np.concatenate([rng.normal(size=(ROWS, 3)), rng.normal(0, 1e3, (ROWS, 3))], axis=1)
    sats[:, :3] *= SAT_DISTANCE / np.linalg.norm(sats[:, :3], axis=1, keepdims=True)
    epochs = []
    for k in range(EPOCH_EVERY, STEPS + 1, EPOCH_EVERY):
        s = 20.0 * t[k]
        z_pr = np.linalg.norm(sats[:, :3] - [s, 0, 0], axis=1) + rng.normal(0, 3.9, ROWS)
        epochs.append(Epoch(t[k], (
            Observation(pr, z_pr[:, None], np.full(ROWS, SIGMA2_PR), sats),
            Observation(dop, rng.normal(0, 0.7, (ROWS, 1)), np.full(ROWS, SIGMA2_DOPPLER),
                        sats))))
    return InputSeries(t=t, u=u, q_c=Q_C), epochs


X0 = np.array([0.5, 0.01, 0.02, 0.0, 20.0, 0.0, 0.0])
P0 = np.diag([1.0, 1.0, 1.0, 1e6, 1.0, 1e6, 1.0])


def _time_engine(backend: str, samples, epochs, cache_dir: str) -> dict:
    start = time.perf_counter()
    filt = CdFilter(attitude_speed_clock_toy(f"bench_{backend.replace('-', '_')}"),
                    FilterConfig(backend=backend, store_every=10,
                                 compile=CompileOptions(cache_dir=cache_dir)))
    build = time.perf_counter() - start
    start = time.perf_counter()
    first = filt.run(samples, epochs, x0=X0, P0=P0)  # includes casadi-jit compilation
    first_s = time.perf_counter() - start
    start = time.perf_counter()
    res = filt.run(samples, epochs, x0=X0, P0=P0)
    run_s = time.perf_counter() - start
    return {"build_s": build, "first_run_s": first_s, "run_s": run_s,
            "x_final": res.x_final.tolist(), "same_as_first": bool(
                np.allclose(first.x_final, res.x_final, rtol=1e-12))}


def _numpy_rows(x: np.ndarray, sats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two measurement models of :func:`_measurements` in plain NumPy: z (2m,), H."""
    los = sats[:, :3] - np.array([x[3], 0.0, 0.0])
    dist = np.linalg.norm(los, axis=1)
    rel_v = sats[:, 3:] - np.array([x[4], 0.0, 0.0])
    rate = np.sum(los * rel_v, axis=1) / dist
    m = sats.shape[0]
    H = np.zeros((2 * m, 7))
    H[:m, 3] = -los[:, 0] / dist
    H[:m, 5] = 1.0
    d_rate_ds = (-rel_v[:, 0] + rate * los[:, 0] / dist) / dist
    H[m:, 3] = d_rate_ds
    H[m:, 4] = -los[:, 0] / dist
    H[m:, 6] = 1.0
    return np.concatenate([dist + x[5], rate + x[6]]), H


def _time_numpy(samples, epochs, fraction: float) -> dict:
    model = attitude_speed_clock_numpy()
    steps = int(STEPS * fraction)
    by_step = {int(round(e.t / DT)): e for e in epochs}
    x, P = X0.copy(), P0.copy()
    zero_p, zero_c = np.zeros(0), np.zeros(2)
    start = time.perf_counter()
    for k in range(steps):
        if k in by_step:
            pr, dop = by_step[k].observations
            z_pred, H = _numpy_rows(x, pr.p)
            z = np.concatenate([pr.z[:, 0], dop.z[:, 0]])
            x, P, _ = kalman_update(x, P, z - z_pred, H, np.concatenate([pr.R, dop.R]))
        out = reference_step(model, x, P, samples.u[k], samples.u[k + 1], zero_p, z_c=zero_c,
                             dt=DT, q_c=Q_C, r_c=zero_c)
        x, P = out["x_next"], out["P_next"]
    elapsed = time.perf_counter() - start
    return {"steps_timed": steps, "timed_s": elapsed, "run_s": elapsed / fraction}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--numpy-fraction", type=float, default=0.05,
                        help="fraction of the run timed for the NumPy loop (scaled up)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    samples, epochs = _scenario(np.random.default_rng(2017))
    duration = STEPS * DT
    with tempfile.TemporaryDirectory() as cache:  # measure a cold compile
        results = {b: _time_engine(b, samples, epochs, cache)
                   for b in ("compiled", "casadi", "casadi-jit")}
    results["numpy"] = _time_numpy(samples, epochs, args.numpy_fraction)
    for entry in results.values():
        entry["real_time_factor"] = duration / entry["run_s"]
    ref = results["numpy"]["run_s"]
    summary = {
        "scenario": {"steps": STEPS, "dt_s": DT, "epochs": len(epochs),
                     "rows_per_epoch": 2 * ROWS, "state": 7, "continuous_measurement": 2},
        "machine": {"python": platform.python_version(), "casadi": ca.__version__,
                    "processor": platform.processor() or platform.machine()},
        "results": results,
        "speedup_vs_numpy": {b: ref / results[b]["run_s"] for b in results if b != "numpy"},
        "acceptance": {"target_run_s": 1.0,
                       "compiled_meets_target": results["compiled"]["run_s"] <= 1.0},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(summary, indent=2))
    tmp.replace(args.out)
    return summary


if __name__ == "__main__":
    out = main()
    for name, entry in out["results"].items():
        print(f"{name:11s} run {entry['run_s']:8.3f} s  x{entry['real_time_factor']:9.0f} "
              f"real time  build {entry.get('build_s', 0.0):6.2f} s")
    print("speed-up vs numpy:", {k: round(v, 1) for k, v in out["speedup_vs_numpy"].items()})
