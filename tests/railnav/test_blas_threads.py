"""`railnav.blas_threads`: the command line's process runs one OpenBLAS thread unless the
user chose a number, counted by the operating system (``/proc/self/task``: the process's
threads), in fresh interpreters."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from railnav.blas_threads import THREAD_VARIABLES, one_blas_thread

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(),
                                reason="counts threads in /proc/self/task (Linux)")

#: Imports NumPy and SciPy's linear algebra (each loads its OpenBLAS) after `FIRST`, then
#: prints the thread count and the variable.
PROBE = """
import json, os
{first}
import numpy, scipy.linalg
print(json.dumps([len(os.listdir("/proc/self/task")),
                  os.environ.get("OPENBLAS_NUM_THREADS")]))
"""


def _probe(first: str, **env: str) -> tuple[int, str | None]:
    clean = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    done = subprocess.run([sys.executable, "-c", PROBE.format(first=first)], check=True,
                          capture_output=True, text=True, cwd=ROOT,
                          env={**clean, "PYTHONPATH": str(ROOT), **env})
    threads, variable = json.loads(done.stdout)
    return threads, variable


def test_the_command_line_starts_one_blas_thread():
    threads, variable = _probe("import railnav.cli")
    assert (threads, variable) == (1, "1")


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS starts no pool on one core")
def test_without_it_openblas_starts_a_pool():
    # the effect the setting removes: NumPy's and SciPy's OpenBLAS each start workers
    threads, variable = _probe("")
    assert threads > 1 and variable is None


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS starts no pool on one core")
@pytest.mark.parametrize("name", THREAD_VARIABLES)
def test_a_users_choice_is_kept(name):
    threads, variable = _probe("import railnav.cli", **{name: "2"})
    assert threads > 1
    assert variable == ("2" if name == "OPENBLAS_NUM_THREADS" else None)


def test_a_process_with_numpy_loaded_is_left_alone(monkeypatch):
    import numpy  # noqa: F401  (loaded: OpenBLAS has read its variables already)
    for name in THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    assert one_blas_thread() is False
    assert "OPENBLAS_NUM_THREADS" not in os.environ
