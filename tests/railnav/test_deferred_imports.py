"""`railnav.deferred_imports`: NumPy's developer tools are not run when SciPy starts, and
work as usual when used.

Each case runs in a fresh interpreter (this session has long imported NumPy's tools). The
reference for "works as usual" is the same call in an interpreter without the deferral.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

#: Import what the engine imports from SciPy, record which of NumPy's tool modules ran
#: (a module's code has run when its own submodules are loaded), then use them.
PROBE = """
import json, sys
if sys.argv[1] == "defer":
    from railnav.deferred_imports import defer_numpy_tools
    defer_numpy_tools()
import scipy.linalg, scipy.special
import numpy as np
ran = sorted(m for m in sys.modules if m.startswith(("numpy.f2py.", "numpy.testing.")))
include = np.f2py.get_include()
try:
    np.testing.assert_allclose(1.0, 1.0 + 1e-3, rtol=1e-6)
    raised = False
except AssertionError:
    raised = True
print(json.dumps({"ran": ran, "include": include, "raised": raised,
                  "solve": scipy.linalg.solve([[2.0, 0.0], [0.0, 4.0]], [1.0, 1.0]).tolist()}))
"""


def _probe(mode: str) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", PROBE, mode], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_numpy_tools_run_only_when_used():
    deferred, plain = _probe("defer"), _probe("plain")
    assert deferred["ran"] == []                       # SciPy's start ran neither tool
    assert deferred["include"] == plain["include"]     # f2py, when used, as without
    assert deferred["raised"] and plain["raised"]      # numpy.testing checks as usual
    assert deferred["solve"] == plain["solve"] == [0.5, 0.25]
